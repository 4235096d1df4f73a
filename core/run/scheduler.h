// Runs the compute phase of one step attempt over a oneTBB flow graph built once per run:
// one continue_node per stage, edges from the step graph, independent stages concurrently.
// Observer stages run afterwards, in order, on the calling thread.
//
// On CUDA every stage gets a stream (a chain shares one; a branch gets its own) and an event:
// a stage waits for its predecessors' events on other streams and records its own, so the
// host only enqueues work and never blocks a oneTBB worker on the GPU. See core/run/cuda/streams.h.
#pragma once
#include <atomic>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/stage/stage.h"
#include "core/run/step_graph.h"

namespace ff {

class StreamSet;  // core/run/cuda/streams.h (CUDA builds)

// One stage instance in a run, with what the core keeps about it.
struct StageSlot {
  std::unique_ptr<Stage> stage;
  RunInfo info;
  RngKey rng;
  Metrics metrics;
  Outcome outcome;
  bool ran = false;          // ran in the current attempt
  double seconds = 0;        // wall time spent in run(), whole run
  // The host's own time in the stage: its field acquires, run() and decide(), less their waits for
  // the device (core/backend/host_wait.h), whole run; `pipeline bench` reports it per step.
  double host_seconds = 0;
  std::uint64_t calls = 0;
};

// A stage's request to run the step again: a rollback (outcome.rollback), or a Δt limit below
// the attempt's Δt (outcome.dt_limit, Outcome::limit_dt).
struct RollbackRequest {
  int node = -1;
  Outcome outcome;
  bool limits_dt() const { return !outcome.rollback; }
};

class Scheduler {
 public:
  Scheduler(const StepGraph& graph, std::vector<StageSlot>& slots, State& state, const RunStats& stats,
            Backend backend);
  ~Scheduler();

  // Runs the compute stages due at `step`. Returns the first rollback request (lowest node
  // index among those that asked), else the first Δt limit below `dt`, or nothing. Exceptions
  // from stages are rethrown here.
  std::optional<RollbackRequest> run_compute(std::uint64_t step, std::uint32_t attempt, double dt, double time);
  // The smallest Δt limit (Outcome::limit_dt) the stages that ran in the last attempt reported;
  // infinity when none did.
  double reported_dt_limit() const;
  // Runs the observer stages due at `step` (the step is accepted; state.step/time updated),
  // calling after_each(node) after each one that ran (so a later observer sees its metrics).
  void run_observers(std::uint64_t step, double dt, double time, const std::function<void(int)>& after_each);
  // Wait for all device work of the step (CUDA); a no-op on the CPU.
  void synchronize();
  // Whether the stages of the next steps may leave their reads past the step
  // (StepContext::may_defer_past_step; the Simulation decides per step).
  void set_step_may_end_pending(bool on) { step_may_end_pending_ = on; }
  // Has every compute stage read back what it left pending (Stage::settle_pending).
  void settle_pending();
  // Whether a stage may leave its host decision to the device (StepContext::gate) when the
  // pipeline allows it (a chain, a decider whose followers all follow the gate, not profiling,
  // alone); on by default.
  void set_device_decisions(bool on) { device_decisions_ = on; }
  CUstream_st* main_stream() const;
  // Profiling: wait for each stage's device work before stopping its clock, so per-stage
  // times are real on CUDA (serializes streams; `pipeline bench` reports both ways).
  void set_profiling(bool on) { profiling_ = on; }
  // Off: every step launches the stages' work directly, never from a captured CUDA graph (tests
  // compare the two); on (the default): steady-state steps are captured when the pipeline
  // allows it (Scheduling::graph_capturable).
  void set_graph_capture(bool on) { graph_capture_ = on; }
  // The rollback snapshot stages reach through StepContext::will_write (null: none), for the
  // nodes whose writes a rollback must undo (`undone[node]`); the others see no snapshot, so
  // their announced writes cost no copy.
  void set_snapshot(Snapshot* snapshot, std::vector<bool> undone) {
    snapshot_ = snapshot;
    snapshot_undone_ = std::move(undone);
  }
  // A rank of a team (core/backend/comm.h; null or one rank: alone). When the run has a rollback
  // snapshot (some stage may request a rollback or limit Δt), the ranks agree at the end of each
  // attempt by one all-reduce: any rollback request rolls every rank back, else the smallest Δt
  // limit any rank exceeded limits every rank, else the step is accepted with the smallest
  // limit reported on any rank. A rank that did not request itself gets a request naming its
  // first stage that may request, with the reason "another rank of the team requested ...".
  void set_team(Communicator* team) { team_ = team; }
  // A decomposed team's rank 0 (core/run/domain.h): observers run on the whole state gathered
  // from every rank, not on the rank's own part.
  void set_observer_state(State* s) { observer_state_ = s; }
  // A decomposed team's ghost exchange, handed to the compute stages (StepContext::ghosts).
  void set_ghosts(GhostExchange* g) { ghosts_ = g; }
  void reset_timers();
  // True once the steady-state step replays a captured CUDA graph (the last step did).
  bool step_is_captured() const;

 private:
  struct Impl;
  Snapshot* snapshot_ = nullptr;
  std::vector<bool> snapshot_undone_;  // per node: its writes are in the snapshot
  void run_node(int node, std::uint64_t step, std::uint32_t attempt, double dt, double time);
  // The context stage `node` sees in run() and after_step().
  StepContext context(int node, CUstream_st* stream, std::uint64_t step, std::uint32_t attempt, double dt,
                      double time);
  void enqueue_compute();  // run every compute stage once (flow graph, or in order for a chain)
  // After a chain whose decider left its decision to the device: the host's decision
  // (Stage::decide), then the followers again, without the gate, from the first that did
  // nothing (all when the gate was closed, else from the first that refused it), unless the
  // decision stops the attempt.
  void resolve_gate();
  bool gating_offered() const;  // the decider may set the gate in this attempt
  void close_gate(CUstream_st* stream);  // a follower refused: the followers after it do nothing
  // The first stage that ran and limited Δt below `dt` (Outcome::limit_dt), if any.
  std::optional<RollbackRequest> exceeded_dt_limit(double dt) const;
  bool run_captured();     // CUDA: replay (capturing first if needed) the step graph
  bool may_capture() const;  // CUDA: some step of this run may yet be replayed from a captured graph
  // In a team: the request every rank acts on (set_team), from this rank's own.
  std::optional<RollbackRequest> agree(std::optional<RollbackRequest> mine);
  Communicator* team_ = nullptr;
  double agreed_dt_limit_ = 0;  // after agree(): the team's reported limit
  bool agreed_ = false;
  std::unique_ptr<Impl> impl_;
  const StepGraph& graph_;
  std::vector<StageSlot>& slots_;
  State& state_;
  State* observer_state_ = nullptr;
  GhostExchange* ghosts_ = nullptr;
  State& state_of(int node);
  // The fields of node's declared accesses in state s, in their order (looked up once).
  const std::vector<Field*>& node_fields(int node, State& s);
  const RunStats& stats_;
  Backend backend_;
  bool profiling_ = false;
  bool graph_capture_ = true;
  bool step_may_end_pending_ = false;
  bool device_decisions_ = true;
  std::atomic<bool> abort_{false};
  std::exception_ptr error_;
  std::atomic<bool> has_error_{false};
};

}  // namespace ff
