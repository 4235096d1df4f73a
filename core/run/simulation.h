// A run: the state, the stage instances, the step graph and its scheduler, rollback and Δt.
// Built from a validated PipelineSpec; `pipeline run`, `pipeline bench` and the integration
// tests all drive this class.
#pragma once
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/input/pipeline_spec.h"
#include "core/stage/registry.h"
#include "core/run/domain.h"
#include "core/run/rollback.h"
#include "core/run/scheduler.h"
#include "core/stage/state.h"
#include "core/run/step_graph.h"

namespace ff {

struct RunOptions {
  Backend backend = Backend::cpu;
  std::string out_dir;         // created if missing; empty = no outputs allowed
  bool force = false;          // overwrite existing outputs
  std::string pipeline_text;   // the YAML text, recorded in outputs (optional)
  bool dry_run = false;        // validate/graph: build everything, touch no files
  // After every rollback, compare the whole state with a copy taken before the step (every
  // field but those only ever written step_local) and stop with a RunError naming what the
  // restore missed. A debugging aid for stage authors: copies the whole state every step.
  bool check_rollbacks = false;
  // A continued run (--resume): outputs that exist are appended to, not refused; the caller
  // restores the checkpoint (core/run/checkpoint.h) before the first step.
  bool resume = false;
  // What produced the run, handed to every stage (RunInfo::record) for outputs to record.
  RunRecord record;
  // This rank's communicator when the run is one of a team (core/run/team.h, `--gpus N`): every
  // rank holds the whole state, or, when every compute stage can run on a slab of particles, its
  // slab and ghosts (core/run/domain.h); stages that split their work use it (RunInfo::team), the
  // ranks agree on every rollback and Δt limit by an all-reduce, and observers (hence every
  // output) exist on rank 0 only. Null: alone.
  Communicator* team = nullptr;
  // Where the stages' messages go (RunInfo::messages): stderr, or the run's log in a process of
  // several runs.
  std::FILE* messages = stderr;
};

class Simulation {
 public:
  // Creates and configures every stage, builds the graph, checks outputs (InputError if an
  // output exists and !force) — nothing is written before all of this has succeeded.
  Simulation(const PipelineSpec& spec, const Registry& registry, RunOptions options);
  // Same, starting from a given state (tests, restarts).
  Simulation(const PipelineSpec& spec, const Registry& registry, RunOptions options, std::unique_ptr<State> state);
  ~Simulation();

  // All remaining steps, then finish(). On an exception, stages are finished with
  // completed=false (outputs are kept as .partial) and the exception propagates.
  void run();
  // One accepted step (with as many rollbacks as it takes). Runs the observers.
  void advance();
  // Flush and close outputs. Called by run(); call it yourself when driving advance().
  void finish(bool completed);

  State& state() { return *state_; }
  // The run's statistics; stats().metrics are the last step's: reading them first has every
  // stage read back what it left past the step (StepContext::may_defer_past_step), which waits for
  // the device and throws the errors those stages report.
  const RunStats& stats() const;
  const StepGraph& graph() const { return *graph_; }
  // The stages that asked for the run's rollbacks, in step order: "step 'ID' asked for K (the
  // last: REASON)". A run whose Δt kept being halved says why at its end.
  std::vector<std::string> rollback_sources() const;
  const std::vector<StageSlot>& slots() const { return slots_; }
  const PipelineSpec& spec() const { return spec_; }
  const DtController& dt() const { return *dt_; }
  std::uint64_t steps_total() const { return spec_.run.steps; }
  // Waits for the device's work and has every stage read back what it left past its step
  // (StepContext::may_defer_past_step): stats().metrics are then the last step's, and errors
  // those stages report are thrown here.
  void synchronize();
  Scheduler& scheduler() { return *scheduler_; }
  // Fields the rollback snapshot holds (empty when no stage may request a rollback).
  // Fields the rollback snapshot copies before every step, and those it copies only when a stage
  // announces a write (Access::on_demand).
  std::vector<std::string> snapshot_fields() const;
  std::vector<std::string> snapshot_on_demand_fields() const;
  // Fields every writer declares Access::step_local: a rollback leaves them as the failed
  // attempt wrote them (they carry nothing into the retry), so check_rollbacks skips them.
  std::vector<std::string> step_local_fields() const;
  // Of those, the ones no step reads before it rewrites them (every writer runs every step, before
  // every other compute stage that reads the field: StepGraph::written_before_read): scratch that
  // carries nothing from one step to the next. A checkpoint leaves them out: their contents
  // between steps are whatever the last step left (on the GPU, in thread order), so two identical
  // runs would otherwise write different checkpoints.
  std::vector<std::string> scratch_fields() const;

  // For checkpoints (core/run/checkpoint.h): the loop's own state besides the fields.
  DtController& dt_controller() { return *dt_; }
  RunStats& run_stats() { return stats_; }
  // A continued run: its first frame was observed by the run that wrote the checkpoint.
  void set_observed_initial() { observed_initial_ = true; }
  // A decomposed team (core/run/domain.h): this rank holds its slab's particles and ghosts; null
  // alone and in a replicated team.
  const Domain* domain() const { return domain_.get(); }
  // Rank 0 of a decomposed team: the whole state its observers see, gathered when one runs.
  State* gathered_state() { return gathered_.get(); }
  // Gathers every particle field into rank 0's gathered_state() now (observers do it on their
  // steps). Every rank of the team calls it; nothing alone.
  void gather();

 private:
  void build(const Registry& registry);
  void check_team(const std::vector<bool>& observer) const;
  // Whether every compute stage can run decomposed (TeamWork::decomposed or local); refuses a
  // mixture, naming the stages.
  bool wants_decomposition(const std::vector<bool>& observer) const;
  void decompose(const std::vector<bool>& observer);
  bool observer_due(std::uint64_t step) const;
  void reduce_metrics();
  void make_snapshot();
  void check_output_names() const;  // InputError: two steps writing one file
  // make_initial_state, its errors located at the pipeline's `init` (or `system`).
  static std::unique_ptr<State> initial_state(const PipelineSpec& spec);
  void prepare_outputs();
  void collect_metrics(int node);
  std::string metric_name_;  // collect_metrics' "stage/metric", its storage reused step to step
  void observe(double dt);
  [[noreturn]] void give_up(const RollbackRequest& req, double dt);
  // Before running a step again (a rollback or a Δt limit): restore the snapshot, and with
  // check_rollbacks prove the restore complete against `before`.
  void restore_for_retry(const RollbackRequest& req, const StateImage* before, std::uint64_t step,
                         std::uint32_t attempt);
  // A stage limited Δt below the attempt's (Outcome::limit_dt): count it and lower Δt, or stop
  // (RunError naming the stage) below dt_min.
  void retry_limited(const RollbackRequest& req, double dt);

  PipelineSpec spec_;
  RunOptions options_;
  std::unique_ptr<State> state_;
  std::vector<StageSlot> slots_;
  std::unique_ptr<StepGraph> graph_;
  std::unique_ptr<Scheduler> scheduler_;
  std::unique_ptr<Snapshot> snapshot_;
  std::unique_ptr<DtController> dt_;
  RunStats stats_;
  // Per compute node: the rollbacks it asked for, and the reason it gave the last time.
  std::vector<std::uint64_t> rollbacks_asked_;
  std::vector<std::string> last_rollback_reason_;
  std::unique_ptr<Domain> domain_;
  std::unique_ptr<State> gathered_;
  std::vector<std::string> gathered_fields_;  // the particle fields rank 0's observers read
  std::vector<GraphNode> observer_schedules_;  // every rank's: when rank 0 gathers (schedule, log steps)
  bool observed_initial_ = false;
  bool finished_ = false;
  // Stages may leave their reads past the step (StepContext::may_defer_past_step) unless the
  // environment has FLIPFLOW_DEFERRED_READS=0 (to compare both ways: the same bits).
  bool deferred_reads_ = true;
  bool pending_possible_ = false;  // a step since the last settle let stages leave reads pending
  void settle_pending();
};

}  // namespace ff
