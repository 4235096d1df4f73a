// observe.h5md: writes chosen fields and the run's observables to an H5MD file
// (core/io/h5md_writer.h has the layout). run() copies the frame into a recycled host buffer and
// hands it to a writer thread, so the following steps compute while HDF5 writes; finish()
// drains the queue and closes (renaming the .partial when the run completed).
//
// A field with one element per particle is written under /particles/all/<name>; any other
// field must be a triangle list (3 x i32 per element) and goes under /connectivity/<name>.
#pragma once
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/observe/h5md/async_writer.h"

namespace ff::observe {

struct H5mdParams {
  std::string file = "trajectory.h5";
  std::vector<std::string> fields{"position", "image"};
  bool observables = true;
  std::int64_t frames_every = 0;
  std::string layout = "h5md";

  template <class P>
  void describe(P& p) {
    p(file, "file", "output file, relative to the run's output directory");
    p(fields, "fields",
      "state fields to write each frame (per-particle fields, or triangle lists); [] for a file of the "
      "observables alone, on a schedule of its own (finer than the frames')");
    p(observables, "observables", "write Δt, rollbacks and every stage metric under /observables");
    p(frames_every, "frames_every",
      "write `fields` only at the steps that are multiples of this (0: at every step this observer runs); the "
      "observables are written at every step it runs, so `every: 10, frames_every: 1000` gives a time series "
      "every 10 steps and a frame every 1000 in one file")
        .at_least(0);
    p(layout, "layout",
      "h5md: the plain H5MD layout; mdanalysis: what MDAnalysis (2.4) opens: a time-dependent box, flat "
      "observable names, and a 2-D run written as 3-D (zero z, nominal Lz = 1; core/io/h5md_writer.h)")
        .one_of({"h5md", "mdanalysis"});
  }
};

class H5mdObserver final : public Stage {
 public:
  static constexpr std::size_t queue_depth = 2;  // frames waiting for the writer thread

  static StageDecl declaration() {
    return {"observe.h5md", "write fields and observables to an H5MD trajectory (written by a background thread)",
            schema_of<H5mdParams>(), {2, 3}, true};
  }

  // Host accesses: on the CUDA backend the core brings the fields to the host.
  H5mdObserver(const ParamValues& v, const RunInfo& info) : H5mdObserver(params_from<H5mdParams>(v), info) {}
  H5mdObserver(H5mdParams p, RunInfo info) : p_(std::move(p)), info_(std::move(info)) {}

  std::vector<Access> accesses() const override;
  void configure(State& state) override;
  Outcome run(StepContext& ctx) override;
  void finish(State& state, bool completed) override;
  std::vector<std::string> outputs() const override { return {p_.file}; }
  // save_state: every frame handed to the writer is written and flushed before the checkpoint.
  // restore_state: continue the file, dropping frames after the checkpoint's step.
  void save_state(StageState& out) override;
  void restore_state(const StageState& saved, State& state) override;

  // Block until every frame handed to the writer thread is on disk (finish() does this too).
  void drain();
  // Where the file goes: the run's output directory joined with `file`.
  std::string path() const;

 private:
  void open(const State& state);
  void copy_frame(StepContext& ctx, Frame& frame, bool with_fields);
  void copy_fields(StepContext& ctx, Frame& frame) const;
  // The metrics reported since their last rows (RunStats::metric_stamps), each at its own step.
  void append_metrics(const RunStats& stats, Frame& frame);
  void note_lost_reports(const std::string& name, const RunStats::Stamp& stamp, std::uint64_t previous_row);
  // Whether this run writes `fields` (frames_every), warning once when the runs step past them.
  bool writes_fields_at(std::uint64_t step);

  H5mdParams p_;
  RunInfo info_;
  bool starts_at_resume_ = false;  // a resumed run's file begun anew after its frames were lost (restore_state)
  std::vector<bool> connectivity_;  // per entry of p_.fields
  std::unique_ptr<AsyncFrameWriter> writer_;
  bool finished_ = false;
  std::optional<std::uint64_t> last_run_step_;  // the step of this observer's previous run
  // When each metric written was reported (RunStats::metric_stamps): one not reported again
  // since is not written again (the writer also drops rows a continued file already has).
  std::map<std::string, std::uint64_t> metric_written_at_;
  // RunStats::Stamp::reports of each observer metric at its last row: reports between two rows
  // were never written (this observer ran less often than the one reporting), said once.
  std::map<std::string, std::uint64_t> metric_reports_written_;
  bool warned_lost_reports_ = false;
  bool warned_frames_every_ = false;
};

}  // namespace ff::observe

FLIPFLOW_HOST_STAGE(ff::observe::H5mdObserver)
