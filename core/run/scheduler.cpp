#include "core/run/scheduler.h"

#include "core/backend/comm.h"
#include "core/backend/host_wait.h"
#include "core/base/error.h"

#include <oneapi/tbb/flow_graph.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <mutex>

#ifdef FLIPFLOW_HAVE_CUDA
#include "core/backend/cuda/check.h"
#include "core/backend/device.h"
#include "core/run/cuda/graph.h"
#include "core/run/cuda/streams.h"
#endif

namespace ff {

namespace flow = tbb::flow;

struct Scheduler::Impl {
  flow::graph graph;
  flow::broadcast_node<flow::continue_msg> start{graph};
  std::vector<std::unique_ptr<flow::continue_node<flow::continue_msg>>> nodes;
  bool chain = false;
  std::vector<int> team_order;  // a branched step's stages one at a time, in a team (enqueue_compute)
  std::vector<int> compute;
  std::mutex error_mutex;
#ifdef FLIPFLOW_HAVE_CUDA
  std::unique_ptr<StreamSet> streams;
  int device = 0;  // the CUDA device the run was made on (its thread's current one)
  std::unique_ptr<DeviceStepParams> device_params;  // when some stage reads ctx.params on CUDA
  CapturedStep captured;
  bool capturable = false;       // every compute stage graph_capturable, none uses `every`
  bool capture_failed = false;
  std::uint64_t steps_run = 0;  // the first runs without the graph, settling every field
  std::vector<int> after_replay;  // compute stages whose after_step runs on replayed steps too (Stage::after_step)
#endif
  // Device decisions (StepContext::gate): the decider's node (-1: none), the compute nodes after
  // it in the chain (each follows the gate), and the gate word (device memory on CUDA, else
  // host_gate). Per attempt: whether the decider set the gate, and the position in `followers`
  // of the first follower that refused it (-1: none).
  int decider = -1;
  std::vector<int> followers;
  unsigned* gate = nullptr;
  unsigned host_gate = 0;
  bool gate_set = false;
  int refused_at = -1;
  // Per-attempt parameters read by the node bodies; `params` is their host copy (ctx.params
  // on the CPU).
  std::uint64_t step = 0;
  std::uint32_t attempt = 0;
  double dt = 0, time = 0;
  StepParams params{};
  // Per node: the fields of its declared accesses, looked up by name once for the state it runs
  // on (node_fields): a std::map lookup by name for every access of every stage was ~8 % of the
  // host's own time a step on CUDA at 2^10 (bench/experiments/README.md, "The host's own time,
  // sampled"). Each node's entry is touched only by the thread running that node.
  std::vector<std::vector<Field*>> fields;
  std::vector<const State*> fields_of;
};

Scheduler::Scheduler(const StepGraph& graph, std::vector<StageSlot>& slots, State& state, const RunStats& stats,
                     Backend backend)
    : impl_(std::make_unique<Impl>()), graph_(graph), slots_(slots), state_(state), stats_(stats), backend_(backend) {
  impl_->compute = graph.compute_nodes();
  impl_->fields.resize(graph.nodes().size());
  impl_->fields_of.assign(graph.nodes().size(), nullptr);
  impl_->chain = graph.is_chain();
  impl_->team_order = graph.compute_order();
#ifdef FLIPFLOW_HAVE_CUDA
  if (backend == Backend::cuda) {
    FF_CUDA_CHECK(cudaGetDevice(&impl_->device), "the run's CUDA device");
    bool device_requests = false;
    for (int i : impl_->compute) device_requests = device_requests || slots[i].stage->scheduling().requests_rollback_on_device;
    impl_->streams = std::make_unique<StreamSet>(graph, device_requests);
    bool any_reads_params = false;
    impl_->capturable = !impl_->compute.empty();
    for (int i : impl_->compute) {
      const Scheduling h = slots[i].stage->scheduling();
      any_reads_params = any_reads_params || h.reads_step_params;
      impl_->capturable = impl_->capturable && h.graph_capturable && graph.nodes()[i].schedule.every_step();
      if (h.reads_step_params) impl_->after_replay.push_back(i);
    }
    // (The upload is on the step's critical path: after the last stage's wait, before the first
    // launch of the next step.)
    if (any_reads_params || impl_->capturable) impl_->device_params = std::make_unique<DeviceStepParams>();
  }
#endif
  // A decider every compute stage after which follows its gate (a chain only: in a branched step
  // the stages after it could run before its run() returns, and on other streams).
  if (impl_->chain) {
    for (std::size_t k = 0; k < impl_->compute.size(); ++k) {
      if (!slots[impl_->compute[k]].stage->scheduling().decides_on_device) continue;
      impl_->decider = impl_->compute[k];
      for (std::size_t j = k + 1; j < impl_->compute.size(); ++j) {
        if (!slots[impl_->compute[j]].stage->scheduling().follows_gate) {
          impl_->decider = -1;
          impl_->followers.clear();
          break;
        }
        impl_->followers.push_back(impl_->compute[j]);
      }
      break;
    }
  }
  impl_->gate = &impl_->host_gate;
#ifdef FLIPFLOW_HAVE_CUDA
  if (impl_->streams) impl_->gate = impl_->streams->gate();
#endif
  // The flow graph is built even for a chain (it is what `graph` prints and what a branch
  // needs); a chain is simply run in order on the calling thread, which is the same schedule
  // without a task hand-off per stage.
  auto& g = impl_->graph;
  impl_->nodes.resize(graph.nodes().size());
  for (int i : impl_->compute) {
    // make_edge registers each predecessor, so the node fires once all of them have.
    impl_->nodes[i] = std::make_unique<flow::continue_node<flow::continue_msg>>(
        g, [this, i](const flow::continue_msg&) {
          run_node(i, impl_->step, impl_->attempt, impl_->dt, impl_->time);
          return flow::continue_msg();
        });
  }
  for (int i : impl_->compute) {
    const auto& preds = graph.nodes()[i].preds;
    if (preds.empty()) flow::make_edge(impl_->start, *impl_->nodes[i]);
    for (int p : preds) flow::make_edge(*impl_->nodes[p], *impl_->nodes[i]);
  }
}

Scheduler::~Scheduler() = default;

CUstream_st* Scheduler::main_stream() const {
#ifdef FLIPFLOW_HAVE_CUDA
  if (impl_->streams) return impl_->streams->main();
#endif
  return nullptr;
}

void Scheduler::run_node(int i, std::uint64_t step, std::uint32_t attempt, double dt, double time) {
  StageSlot& slot = slots_[i];
  const GraphNode& node = graph_.nodes()[i];
  slot.ran = false;
  if (abort_.load(std::memory_order_relaxed)) return;
  try {
    CUstream_st* stream = nullptr;
#ifdef FLIPFLOW_HAVE_CUDA
    if (impl_->streams) {
      // A branched step runs its stages on oneTBB's workers, whose current device is any: this
      // run's (a rank of a team, or an in-process sweep's run, may be on another GPU than 0).
      if (!impl_->chain) use_cuda_device(impl_->device);
      impl_->streams->before(i);
      stream = impl_->streams->stream(i);
      // A stage not due this step still joins its predecessors and records its event: a
      // successor on another stream waits on that event alone, so it would otherwise not be
      // ordered after this step's work before it (test_scheduler, "a stage skipped by every").
      if (!node.runs_at(step)) impl_->streams->after(i);
    }
#endif
    if (!node.runs_at(step)) return;
    const auto host0 = std::chrono::steady_clock::now();
    const double waited0 = host_wait_seconds();
    const std::vector<Field*>& fields = node_fields(i, state_of(i));
    for (std::size_t k = 0; k < fields.size(); ++k)
      fields[k]->acquire(node.accesses[k].where, node.accesses[k].mode, stream);
    slot.metrics.clear();
    StepContext ctx = context(i, stream, step, attempt, dt, time);
    const auto t0 = std::chrono::steady_clock::now();
    slot.outcome = slot.stage->run(ctx);
    if (ctx.gate && i == impl_->decider) {
      impl_->gate_set = ctx.gate_set;
    } else if (ctx.gate && ctx.gate_refused && impl_->refused_at < 0) {
      close_gate(stream);
      const auto& f = impl_->followers;
      impl_->refused_at = int(std::find(f.begin(), f.end(), i) - f.begin());
    }
#ifdef FLIPFLOW_HAVE_CUDA
    if (profiling_ && stream) impl_->streams->synchronize();
#endif
    const auto t1 = std::chrono::steady_clock::now();
    slot.seconds += std::chrono::duration<double>(t1 - t0).count();
    slot.host_seconds += std::chrono::duration<double>(t1 - host0).count() - (host_wait_seconds() - waited0);
    ++slot.calls;
    slot.ran = true;
#ifdef FLIPFLOW_HAVE_CUDA
    if (impl_->streams) impl_->streams->after(i);
#endif
    // A rollback request, or a Δt limit below this attempt's Δt: the stages not yet started skip.
    if (slot.outcome.rollback || slot.outcome.dt_limit < dt) abort_.store(true);
  } catch (...) {
    std::lock_guard<std::mutex> lock(impl_->error_mutex);
    if (!error_) error_ = std::current_exception();
    has_error_.store(true);
    abort_.store(true);
  }
}

StepContext Scheduler::context(int i, CUstream_st* stream, std::uint64_t step, std::uint32_t attempt, double dt,
                               double time) {
  StageSlot& slot = slots_[i];
  DeviceRollbackFlag* flag = nullptr;
  const StepParams* params = &impl_->params;
#ifdef FLIPFLOW_HAVE_CUDA
  if (impl_->streams) {
    flag = impl_->streams->rollback_flag(i);
    params = impl_->device_params ? impl_->device_params->device() : nullptr;
  }
#endif
  StepContext ctx{state_of(i), slot.info, stats_, step, attempt, dt, time, backend_, stream, slot.rng, slot.metrics,
                 flag,   params, snapshot_undone_.size() > std::size_t(i) && snapshot_undone_[i] ? snapshot_ : nullptr};
  if (!graph_.nodes()[i].observer) ctx.ghosts = ghosts_;
  ctx.step_may_end_pending = step_may_end_pending_ && !profiling_ && !graph_.nodes()[i].observer;
  if (i == impl_->decider ? gating_offered()
                          : impl_->gate_set && std::find(impl_->followers.begin(), impl_->followers.end(), i) !=
                                                   impl_->followers.end())
    ctx.gate = impl_->gate;
  return ctx;
}

std::optional<RollbackRequest> Scheduler::run_compute(std::uint64_t step, std::uint32_t attempt, double dt,
                                                      double time) {
  abort_.store(false);
  agreed_ = false;
  error_ = nullptr;
  has_error_.store(false);
  impl_->gate_set = false;  // (an attempt that threw may have left them set)
  impl_->refused_at = -1;
  impl_->step = step;
  impl_->attempt = attempt;
  impl_->dt = dt;
  impl_->time = time;
  impl_->params = StepParams{step, attempt, dt, time};
#ifdef FLIPFLOW_HAVE_CUDA
  // Steps never replayed from a graph (a rollback snapshot, or nothing to capture) take their
  // parameters from slots uploaded ahead (DeviceStepParams::set).
  if (impl_->device_params)
    impl_->device_params->set(impl_->params, main_stream(), !may_capture() && !impl_->captured.ready());
  const bool captured = run_captured();
  if (captured) {
    ++impl_->steps_run;
  } else
#endif
  {
#ifdef FLIPFLOW_HAVE_CUDA
    if (impl_->streams) impl_->streams->begin_attempt();
#endif
    enqueue_compute();
    if (!error_) resolve_gate();
#ifdef FLIPFLOW_HAVE_CUDA
    if (impl_->streams) ++impl_->steps_run;
#endif
  }
  if (error_) std::rethrow_exception(error_);
#ifdef FLIPFLOW_HAVE_CUDA
  if (impl_->streams) {
    // Stages that may request a rollback on the device report through flags read once here.
    // A replayed graph joined its own forks (its events exist only inside the graph).
    if (!captured) impl_->streams->join_all();
    if (auto req = impl_->streams->read_rollback_flags(graph_, slots_)) return agree(std::move(req));
  }
#endif
  for (int i : impl_->compute)
    if (slots_[i].ran && slots_[i].outcome.rollback) return agree(RollbackRequest{i, slots_[i].outcome});
  if (auto limit = agree(exceeded_dt_limit(dt))) return limit;
#ifdef FLIPFLOW_HAVE_CUDA
  if (captured) {
    // A replayed step is accepted (no stage of a captured step may request a rollback); stages
    // that read ctx.params may look at what their kernels published in host memory (Stage::after_step).
    for (int i : impl_->after_replay) {
      StepContext ctx = context(i, main_stream(), step, attempt, dt, time);
      slots_[i].stage->after_step(ctx);
    }
    return std::nullopt;
  }
#endif
  // The step is accepted: stages that left results on the device read them now (in step order,
  // which for a chain is the order their work was enqueued).
  for (int i : impl_->compute) {
    if (!slots_[i].ran) continue;
    CUstream_st* stream = nullptr;
#ifdef FLIPFLOW_HAVE_CUDA
    if (impl_->streams) stream = impl_->streams->stream(i);
#endif
    StepContext ctx = context(i, stream, step, attempt, dt, time);
    slots_[i].stage->after_step(ctx);
  }
  return std::nullopt;
}

std::optional<RollbackRequest> Scheduler::exceeded_dt_limit(double dt) const {
  for (int i : impl_->compute)
    if (slots_[i].ran && slots_[i].outcome.dt_limit < dt) return RollbackRequest{i, slots_[i].outcome};
  return std::nullopt;
}

std::optional<RollbackRequest> Scheduler::agree(std::optional<RollbackRequest> mine) {
  if (!in_team(team_) || !snapshot_) return mine;  // alone, or nothing can request
  constexpr double inf = std::numeric_limits<double>::infinity();
  // One all-reduce (max) of: a rollback request, minus the Δt limit exceeded, minus the
  // smallest limit reported (so max gives the smallest limit).
  double v[3] = {mine && mine->outcome.rollback ? 1.0 : 0.0, mine && mine->limits_dt() ? -mine->outcome.dt_limit : -inf,
                 -reported_dt_limit()};
  team_->all_reduce(v, 3, ReduceOp::max);
  agreed_ = true;
  agreed_dt_limit_ = -v[2];
  const bool rollback = v[0] > 0, limit = v[1] > -inf;
  if (!rollback && !limit) return std::nullopt;
  if (mine && mine->outcome.rollback == rollback && (rollback || mine->outcome.dt_limit == -v[1])) return mine;
  // Another rank's request: this rank acts on it in the name of its first stage that could have made it.
  int node = impl_->compute.empty() ? 0 : impl_->compute.front();
  for (int i : impl_->compute) {
    const Scheduling sch = slots_[i].stage->scheduling();
    if (rollback ? sch.may_request_rollback : sch.may_limit_dt) {
      node = i;
      break;
    }
  }
  const std::string who = "another rank of the team (" + std::to_string(team_->size()) + " ranks) ";
  if (rollback) return RollbackRequest{node, Outcome::request_rollback(who + "requested a rollback")};
  return RollbackRequest{node, Outcome::limit_dt(-v[1], who + "limited Δt")};
}

double Scheduler::reported_dt_limit() const {
  if (agreed_) return agreed_dt_limit_;
  double limit = std::numeric_limits<double>::infinity();
  for (int i : impl_->compute)
    if (slots_[i].ran) limit = std::min(limit, slots_[i].outcome.dt_limit);
  return limit;
}

bool Scheduler::gating_offered() const {
  return device_decisions_ && impl_->decider >= 0 && !profiling_ && !in_team(team_) && !ghosts_;
}

void Scheduler::close_gate(CUstream_st* stream) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (impl_->gate != &impl_->host_gate) {
    FF_CUDA_CHECK(cudaMemsetAsync(impl_->gate, 1, sizeof(unsigned), stream), "closing the gate");
    return;
  }
#endif
  (void)stream;
  impl_->host_gate = 1;
}

void Scheduler::resolve_gate() {
  auto& im = *impl_;
  if (!im.gate_set) {
    im.refused_at = -1;
    return;
  }
  const int d = im.decider;
  StageSlot& slot = slots_[d];
  Stage::Decision decision;
  try {
    CUstream_st* stream = nullptr;
#ifdef FLIPFLOW_HAVE_CUDA
    if (im.streams) stream = im.streams->stream(d);
#endif
    StepContext ctx = context(d, stream, im.step, im.attempt, im.dt, im.time);
    const auto t0 = std::chrono::steady_clock::now();
    const double waited0 = host_wait_seconds();
    decision = slot.stage->decide(ctx);
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    slot.seconds += took;
    slot.host_seconds += took - (host_wait_seconds() - waited0);
  } catch (...) {
    error_ = std::current_exception();
    has_error_.store(true);
    im.gate_set = false;
    im.refused_at = -1;
    return;
  }
  im.gate_set = false;  // the followers run again without it
  slot.outcome = decision.outcome;
  if (decision.open && (slot.outcome.rollback || slot.outcome.limits_dt())) {
    // The followers' gated work stands and no snapshot covers it: the attempt cannot be undone.
    error_ = std::make_exception_ptr(RunError("stage '" + graph_.nodes()[d].id +
                                              "' decided a rollback or a Δt limit (Stage::decide) with its "
                                              "gate open"));
    has_error_.store(true);
    im.refused_at = -1;
    return;
  }
  const int from = decision.open ? im.refused_at : 0;
  im.refused_at = -1;
  if (slot.outcome.rollback || slot.outcome.dt_limit < im.dt) {
    abort_.store(true);
    return;
  }
  if (from < 0) return;
  for (std::size_t k = std::size_t(from); k < im.followers.size(); ++k)
    run_node(im.followers[k], im.step, im.attempt, im.dt, im.time);
}

void Scheduler::enqueue_compute() {
  if (impl_->chain) {
    for (int i : impl_->compute) run_node(i, impl_->step, impl_->attempt, impl_->dt, impl_->time);
  } else if (in_team(team_)) {
    // Stages talk to the other ranks from run() (all-gathers, reductions), and every rank must
    // make those calls in the same order, one at a time: in a team a branched step runs its
    // stages in one order all ranks share. (On CUDA the branches' streams still overlap.)
    for (int i : impl_->team_order) run_node(i, impl_->step, impl_->attempt, impl_->dt, impl_->time);
  } else {
    impl_->start.try_put(flow::continue_msg());
    impl_->graph.wait_for_all();
  }
}

bool Scheduler::may_capture() const {
#ifdef FLIPFLOW_HAVE_CUDA
  return impl_->capturable && !snapshot_ && graph_capture_ && !impl_->capture_failed;
#else
  return false;
#endif
}

bool Scheduler::run_captured() {
#ifdef FLIPFLOW_HAVE_CUDA
  auto& im = *impl_;
  // The first step runs directly so every field is settled on the device before capture;
  // profiling needs each stage's own launches. A run with a rollback snapshot is never captured:
  // the snapshot's on-demand copies and storage swaps (will_write, will_overwrite) are decided
  // on the host in each step, which a replayed graph would skip.
  if (!may_capture() || profiling_ || im.steps_run == 0) return false;
  if (!im.captured.ready()) {
    std::string why;
    const bool ok = im.captured.capture(main_stream(), [&] {
      im.streams->begin_attempt();
      enqueue_compute();
      if (error_) std::rethrow_exception(error_);
      im.streams->join_all();
      launch_advance_step(im.device_params->device(), main_stream());
    }, why);
    if (!ok) {
      // Not fatal: the step runs with direct launches from now on.
      im.capture_failed = true;
      error_ = nullptr;
      abort_.store(false);
      return false;
    }
  }
  // The graph reads and writes what the stages declared: bring what the host wrote since the last
  // step over first (as run_node does before a stage runs; after the launch the copy would
  // overwrite the step's results), and keep host/device coherence flags true.
  for (int i : im.compute) {
    const auto& accesses = graph_.nodes()[i].accesses;
    const std::vector<Field*>& fields = node_fields(i, state_);
    for (std::size_t k = 0; k < fields.size(); ++k) fields[k]->acquire(accesses[k].where, accesses[k].mode, main_stream());
  }
  im.captured.launch(main_stream());
  im.device_params->advanced_by_graph();
  for (int i : im.compute) {
    slots_[i].ran = true;
    slots_[i].outcome = Outcome::ok();
    slots_[i].metrics.clear();
  }
  return true;
#else
  return false;
#endif
}

bool Scheduler::step_is_captured() const {
#ifdef FLIPFLOW_HAVE_CUDA
  return impl_->captured.ready() && !profiling_ && graph_capture_;
#else
  return false;
#endif
}

const std::vector<Field*>& Scheduler::node_fields(int node, State& s) {
  std::vector<Field*>& f = impl_->fields[std::size_t(node)];
  if (impl_->fields_of[std::size_t(node)] != &s) {  // a State never removes a field or moves one
    f.clear();
    for (auto& a : graph_.nodes()[std::size_t(node)].accesses) f.push_back(&s.field(a.field));
    impl_->fields_of[std::size_t(node)] = &s;
  }
  return f;
}

State& Scheduler::state_of(int node) {
  return observer_state_ && graph_.nodes()[node].observer ? *observer_state_ : state_;
}

void Scheduler::run_observers(std::uint64_t step, double dt, double time,
                              const std::function<void(int)>& after_each) {
  for (int i : graph_.observer_nodes()) {
    run_node(i, step, 0, dt, time);
    if (error_) std::rethrow_exception(error_);
    if (slots_[i].ran) after_each(i);
  }
}

void Scheduler::reset_timers() {
  for (auto& s : slots_) {
    s.seconds = 0;
    s.host_seconds = 0;
    s.calls = 0;
  }
}

void Scheduler::synchronize() {
#ifdef FLIPFLOW_HAVE_CUDA
  if (impl_->streams) impl_->streams->synchronize();
#endif
}

void Scheduler::settle_pending() {
  for (int i : impl_->compute) {
    CUstream_st* stream = nullptr;
#ifdef FLIPFLOW_HAVE_CUDA
    if (impl_->streams) stream = impl_->streams->stream(i);
#endif
    StepContext ctx = context(i, stream, impl_->step, impl_->attempt, impl_->dt, impl_->time);
    slots_[i].stage->settle_pending(ctx);
  }
}

}  // namespace ff
