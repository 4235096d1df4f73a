// Checkpoints: everything a run needs to continue bit for bit, in one file per checkpoint
// (core/io/checkpoint_file.h stores and verifies it). Our noise is counter-based (Philox keyed
// by seed and stage, counted by particle, step and attempt), so there is no generator state to
// save: the clock is the generator's state.
//
// A checkpoint at step S is taken between steps, after step S's observers ran, and holds:
//   fields/<name>          every field of the state (count x components, its element type)
//   clock/step, clock/time, box/L, species/names, species/diameter
//   dt/current, dt/streak, dt/limit
//                          the Δt controller (the rollback policy's Δt, good steps since the
//                          last rollback, the last Δt limit a stage reported: DtController);
//                          dt/nominal, dt/min, dt/grow_after as configured
//   stats/...              whole-run counters (rollbacks) and the last metric of every stage,
//                          which observe.h5md writes each frame even when a stage ran before
//   stages/<id>/<name>     each stage's own state (Stage::save_state): observe.msd's reference
//                          positions, observe.gr's histogram, neighbors.verlet's build flag
//   pipeline/text, pipeline/effective, pipeline/resolved, pipeline/structure
//                          the file as given, after --set, every parameter resolved, and the
//                          structure a continuation must share (N, dimension, precision,
//                          stages, fields)
//   meta/...               flipflow version and commit, backend, history of continuations
// Files are <out>/checkpoint-<step, 12 digits>.h5; the newest `keep` are kept.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/input/pipeline_spec.h"
#include "core/io/checkpoint_file.h"
#include "core/run/simulation.h"

namespace ff {

// "checkpoint-000000001000.h5"
std::string checkpoint_file_name(std::uint64_t step);
// The checkpoint files in `dir` with their steps, newest (highest step) first; none when it does
// not exist.
std::vector<std::pair<std::uint64_t, std::string>> checkpoint_files(const std::string& dir);

// The parameter lines of a pipeline ("run.dt = 0.01", "step.abp.integrate.v0 = 1", ...): every
// value after defaults and --set, one key per line, sorted. Structure lines apart.
std::vector<std::string> resolved_parameters(const PipelineSpec& spec);
// What a continuation must share with its checkpoint: dimensions, N, precision, the stages in
// order ("step[2] = delaunay.flip (id delaunay.flip)").
std::vector<std::string> pipeline_structure(const PipelineSpec& spec);

// Writes checkpoints of a running simulation into `dir`.
class Checkpointer {
 public:
  // every = 0: only when asked (write()). keep >= 1 newest files are kept.
  Checkpointer(Simulation& sim, std::string dir, std::uint64_t every, std::uint64_t keep, RunRecord record,
               std::string history = "");
  // After an accepted step: writes a checkpoint when `every` divides the step.
  void after_step();
  // Writes a checkpoint of the state now (a no-op when one of this step exists). Returns its path.
  std::string write();
  std::uint64_t written() const { return written_; }
  // The newest checkpoint this Checkpointer wrote and its step (empty, 0: none yet).
  std::string newest() const;
  std::uint64_t newest_step() const { return written_ ? last_step_ : 0; }
  // What the checkpoints written so far cost: seconds in write() after the device was idle
  // (collecting the state, writing, syncing and renaming the file), and the newest file's size.
  double write_seconds() const { return write_seconds_; }
  std::uint64_t last_bytes() const { return last_bytes_; }

 private:
  void prune() const;
  Simulation& sim_;
  std::string dir_;
  std::uint64_t every_, keep_;
  RunRecord record_;
  std::string history_;
  std::uint64_t last_step_ = ~std::uint64_t(0);
  std::uint64_t written_ = 0;
  double write_seconds_ = 0;
  std::uint64_t last_bytes_ = 0;
};

// The checkpoint to continue from.
struct ResumePoint {
  std::string path;
  CheckpointData data;
  // Newer checkpoints refused, with why (renamed *.invalid): the caller warns of each
  // (`pipeline run` in its log, which is its run.log in an in-process sweep).
  std::vector<std::string> skipped;
};
// `where` is a checkpoint file (used as it is; InputError if it is not valid) or an output
// directory: its newest valid checkpoint, skipping (and renaming to <name>.invalid, with a
// warning) newer ones that fail to read or verify. InputError when there is none.
ResumePoint find_resume_point(const std::string& where);

// What differs between a checkpoint and the pipeline that would continue it.
struct PipelineChanges {
  std::vector<std::string> structure;   // refused: the continuation cannot be the same run
  std::vector<std::string> parameters;  // allowed with --allow-changes ("run.dt: 0.01 -> 0.005")
};
// run.steps and run.checkpoint may change freely (extending a run); they are not listed.
PipelineChanges compare_with_checkpoint(const CheckpointData& data, const PipelineSpec& spec);

// A state to configure the continued run's stages on: box, species and the four fields every
// run has, from the checkpoint (restore_checkpoint then overwrites every field).
std::unique_ptr<State> state_from_checkpoint(const CheckpointData& data);

// After constructing the Simulation on state_from_checkpoint(...): every field (checking that the
// configured stages made the same fields), the clock, Δt controller, run statistics and every
// stage's own state. InputError naming the first difference when the fields do not match.
void restore_checkpoint(Simulation& sim, const CheckpointData& data);

// The history of continuations recorded in a checkpoint ("" for a run never resumed).
std::string checkpoint_history(const CheckpointData& data);
// The --set arguments of the run that wrote the checkpoint, in order (empty for a checkpoint
// written before they were recorded): a continuation applies them before its own.
std::vector<std::string> checkpoint_overrides(const CheckpointData& data);

}  // namespace ff
