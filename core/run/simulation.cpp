#include "core/run/simulation.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <sstream>

#include "core/backend/comm.h"
#include "core/base/error.h"
#include "core/input/init.h"

namespace fs = std::filesystem;

namespace ff {

Simulation::Simulation(const PipelineSpec& spec, const Registry& registry, RunOptions options)
    : Simulation(spec, registry, std::move(options), initial_state(spec)) {}

std::unique_ptr<State> Simulation::initial_state(const PipelineSpec& spec) {
  try {
    // A random start keeps the centres off the walls of the pipeline's overlap correction.
    return make_initial_state(spec.system, spec.run.precision, spec.run.seed, wall_axis(spec));
  } catch (const InputError& e) {
    if (spec.system.where.str().empty()) throw;
    // (the file's place of `init`, and the --set arguments that changed the system)
    throw InputError(spec.system.where.str() + set_by_note(spec.system.set_by) + ": " + e.what());
  }
}

Simulation::Simulation(const PipelineSpec& spec, const Registry& registry, RunOptions options,
                       std::unique_ptr<State> state)
    : spec_(spec), options_(std::move(options)), state_(std::move(state)) {
  build(registry);
  check_output_names();
  if (!options_.dry_run) prepare_outputs();
}

Simulation::~Simulation() {
  if (!finished_) {
    try {
      finish(false);
    } catch (...) {
      // Destructors must not throw; the run already failed if we get here.
    }
  }
}

void Simulation::build(const Registry& registry) {
  // In a team, observers (and so every output) live on rank 0 only; the other ranks run the
  // compute stages on their copies of the state.
  for (auto& e : spec_.step)
    if (registry.get(e.stage).decl.observer) {
      GraphNode when;  // only its schedule: GraphNode::runs_at answers for every rank
      when.schedule = e.schedule;
      if (e.schedule.log) when.steps = e.schedule.log_steps(spec_.run.steps + 1);  // as StepGraph: observers see the last step
      observer_schedules_.push_back(std::move(when));
    }
  if (in_team(options_.team) && options_.team->rank() != 0) {
    std::vector<StepEntry> compute;
    for (auto& e : spec_.step)
      if (!registry.get(e.stage).decl.observer) compute.push_back(e);
    spec_.step = std::move(compute);
  }
  std::vector<std::vector<Access>> accesses;
  std::vector<bool> observer;
  slots_.resize(spec_.step.size());
  for (std::size_t i = 0; i < spec_.step.size(); ++i) {
    const StepEntry& e = spec_.step[i];
    StageSlot& slot = slots_[i];
    slot.info = RunInfo{state_->dim(), spec_.run.precision, options_.backend, spec_.run.seed, spec_.run.steps,
                        spec_.run.dt,  options_.out_dir,    spec_.file,       e.id,  options_.record,
                        options_.team, options_.messages};
    slot.rng = make_rng_key(spec_.run.seed, e.id.c_str());
    try {
      slot.stage = registry.create(e.stage, options_.backend, e.params, slot.info);
      slot.stage->configure(*state_);
    } catch (const InputError& err) {
      // Stages often start their messages with their own name: once is enough, and a step with an
      // id of its own names its stage.
      std::string what = err.what();
      const bool named = what.rfind(e.stage + ": ", 0) == 0;
      if (named && e.id == e.stage) what.erase(0, e.stage.size() + 2);
      throw InputError(e.where.str() + ": step '" + e.id + "'" + (named || e.id == e.stage ? "" : " (" + e.stage + ")") +
                       set_by_note(e.set_by) + ": " + what);
    }
    accesses.push_back(slot.stage->accesses());
    for (auto& a : accesses.back())
      if (!state_->has_field(a.field))
        throw InputError(e.where.str() + ": step '" + e.id + "' uses field '" + a.field +
                         "', which no stage before it created");
    const StageDecl& decl = registry.get(e.stage).decl;
    observer.push_back(decl.observer);
    if (!decl.needs_before.empty()) {
      bool found = false;
      for (std::size_t j = 0; j < i && !found; ++j)
        for (auto& need : decl.needs_before) found = found || registry.get(spec_.step[j].stage).decl.name == need;
      if (!found) {
        std::string names;
        for (std::size_t k = 0; k < decl.needs_before.size(); ++k)
          names += (k ? (k + 1 == decl.needs_before.size() ? " or " : ", ") : "") + decl.needs_before[k];
        throw InputError(e.where.str() + ": step '" + e.id + "' (" + decl.name + ") needs " + names +
                         " earlier in the step");
      }
    }
  }
  graph_ = std::make_unique<StepGraph>(spec_, std::move(accesses), observer);
  rollbacks_asked_.assign(graph_->nodes().size(), 0);
  last_rollback_reason_.assign(graph_->nodes().size(), "");
  if (!in_team(options_.team) || options_.team->rank() == 0)
    for (auto& list : {graph_->repeated_movers(spec_), graph_->unread_writes(spec_),
                       graph_->periodic_cells_in_slab(spec_), graph_->stale_observer_fields(spec_)})
      for (auto& w : list) std::fprintf(options_.messages, "flipflow: warning: %s\n", w.c_str());
  const bool decomposed = in_team(options_.team) && wants_decomposition(observer);
  if (in_team(options_.team) && !decomposed) check_team(observer);
  scheduler_ = std::make_unique<Scheduler>(*graph_, slots_, *state_, stats_, options_.backend);
  scheduler_->set_team(options_.team);
  if (decomposed) decompose(observer);
  // No rank captures its step into a CUDA graph: a capture on one rank's thread would be broken
  // by another rank's allocations or waits in the same process (as for `pipeline sweep
  // --in-process`). The same bits, launched directly.
  if (in_team(options_.team)) scheduler_->set_graph_capture(false);
  if (const char* e = std::getenv("FLIPFLOW_DEFERRED_READS")) deferred_reads_ = std::string(e) != "0";
  // Device decisions (StepContext::gate): on unless FLIPFLOW_DEVICE_DECISIONS=0 (A/B runs and tests).
  if (const char* e = std::getenv("FLIPFLOW_DEVICE_DECISIONS")) scheduler_->set_device_decisions(std::string(e) != "0");
  dt_ = std::make_unique<DtController>(spec_.run.dt, spec_.run.dt_min, spec_.run.dt_grow_after);
  stats_.dt = spec_.run.dt;

  make_snapshot();
}

bool Simulation::observer_due(std::uint64_t step) const {
  return std::any_of(observer_schedules_.begin(), observer_schedules_.end(),
                     [&](const GraphNode& when) { return when.runs_at(step); });
}

// What a rollback must restore: the writes of every stage that can run before a rollback
// request is seen. A request returned by run() stops the step at once (the scheduler skips what
// has not started), so the writes of a stage that runs after every stage that may request one —
// Lawson flips and the overlap correction after detect_inversion and flip — need no copy. On
// CUDA a stage may also request from its kernels (device flags read at the end of the step);
// when one may, every stage counts. Writes declared on_demand are copied only when the stage
// announces them. A stage that may limit Δt (Outcome::limit_dt) counts as a requester from run():
// the step runs again at the limited Δt from the state it started with, so what the stages
// before it wrote (having used the old Δt, or read what another wrote) is restored; a limiter
// placed first in the step, as delaunay.dt_bound is, adds nothing to the snapshot.
void Simulation::make_snapshot() {
  std::vector<int> requesters;
  bool device_requests = false;
  for (int i : graph_->compute_nodes())
    if (slots_[i].stage->scheduling().may_request_rollback || slots_[i].stage->scheduling().may_limit_dt) {
      requesters.push_back(i);
      device_requests = device_requests || slots_[i].stage->scheduling().requests_rollback_on_device;
    }
  if (requesters.empty()) return;
  // In a team every rank rolls back when any rank requests (the scheduler agrees by an
  // all-reduce at the end of the attempt), so a rank that ran the whole step must be able to
  // undo the writes of the stages after the requester too: then, as for device requests, every
  // stage counts.
  const bool host_requests_only =
      (options_.backend == Backend::cpu || !device_requests) && !in_team(options_.team);
  std::set<std::string> every_step, on_demand;
  std::vector<bool> undone(graph_->nodes().size(), false);
  for (int j : graph_->compute_nodes()) {
    bool before_a_request = !host_requests_only;
    for (int k : requesters) before_a_request = before_a_request || k == j || !graph_->ordered(k, j);
    if (!before_a_request) continue;
    undone[j] = true;
    for (auto& a : graph_->nodes()[j].accesses)
      if (writes(a.mode) && !(a.step_local && graph_->written_before_read(j, a.field)))
        (a.on_demand ? on_demand : every_step).insert(a.field);
  }
  for (auto& f : every_step) on_demand.erase(f);
  snapshot_ = std::make_unique<Snapshot>(std::vector<std::string>(every_step.begin(), every_step.end()),
                                         std::vector<std::string>(on_demand.begin(), on_demand.end()));
  scheduler_->set_snapshot(snapshot_.get(), std::move(undone));
}

std::vector<std::string> Simulation::snapshot_fields() const {
  return snapshot_ ? snapshot_->fields() : std::vector<std::string>{};
}

std::vector<std::string> Simulation::snapshot_on_demand_fields() const {
  return snapshot_ ? snapshot_->on_demand_fields() : std::vector<std::string>{};
}

namespace {

// The fields every compute stage that writes them writes so that `local(node, access)` holds.
template <class Local>
std::vector<std::string> fields_written_only(const StepGraph& graph, Local local) {
  std::set<std::string> yes, no;
  for (int j : graph.compute_nodes())
    for (auto& a : graph.nodes()[j].accesses)
      if (writes(a.mode)) (local(j, a) ? yes : no).insert(a.field);
  std::vector<std::string> out;
  for (auto& f : yes)
    if (!no.count(f)) out.push_back(f);
  return out;
}

}  // namespace

std::vector<std::string> Simulation::step_local_fields() const {
  return fields_written_only(*graph_, [](int, const Access& a) { return a.step_local; });
}

std::vector<std::string> Simulation::scratch_fields() const {
  return fields_written_only(*graph_, [this](int j, const Access& a) {
    return a.step_local && graph_->written_before_read(j, a.field);
  });
}

void Simulation::collect_metrics(int node) {
  const auto& values = slots_[node].metrics.values();
  if (values.empty()) return;
  const bool only_in_observables = graph_->nodes()[std::size_t(node)].observer && slots_[node].stage->outputs().empty();
  for (auto& kv : values) {
    std::string& name = metric_name_;
    name.assign(slots_[node].info.stage_id).append(1, '/').append(kv.first);
    stats_.metrics[name] = kv.second;
    RunStats::Stamp& stamp = stats_.metric_stamps[name];
    stamp = {state_->step, state_->time, stamp.reports + 1, only_in_observables};
  }
}

void Simulation::gather() {
  if (!domain_) return;
  domain_->gather(*state_, gathered_.get(), state_->particle_field_names());
  if (gathered_) {
    gathered_->step = state_->step;
    gathered_->time = state_->time;
  }
}

void Simulation::observe(double dt) {
  if (domain_ && observer_due(state_->step)) gather();
  scheduler_->run_observers(state_->step, dt, state_->time, [this](int node) { collect_metrics(node); });
}

void Simulation::give_up(const RollbackRequest& req, double dt) {
  std::ostringstream os;
  os << "step " << state_->step << ": stage '" << graph_->nodes()[req.node].id << "' requested a rollback ("
     << req.outcome.reason << ") and Δt = " << dt << " cannot be halved again without going below dt_min = "
     << dt_->min();
  if (!req.outcome.particles.empty()) {
    os << "; particles involved:";
    for (std::size_t k = 0; k < req.outcome.particles.size() && k < 8; ++k) os << " " << req.outcome.particles[k];
  }
  os << ". Lower run.dt, or check the model's forces for a blow-up.";
  throw RunError(os.str());
}

void Simulation::restore_for_retry(const RollbackRequest& req, const StateImage* before, std::uint64_t step,
                                   std::uint32_t attempt) {
  const std::string& id = graph_->nodes()[req.node].id;
  if (!snapshot_)  // (only a limit can get here: a stage that did not declare it may limit Δt)
    throw RunError("step " + std::to_string(step) + ": stage '" + id +
                   "' limited Δt (Outcome::limit_dt) but its Stage::scheduling() does not set may_limit_dt, so "
                   "the core kept no snapshot to run the step again from; set it in the stage");
  snapshot_->restore(*state_, scheduler_->main_stream());
  if (!before) return;
  const std::string missed = before->differences(*state_);
  if (!missed.empty())
    throw RunError("step " + std::to_string(step) + ", attempt " + std::to_string(attempt) + ": the " +
                   (req.limits_dt() ? "Δt limit" : "rollback") + " requested by stage '" + id +
                   "' did not restore the state (check_rollbacks): " + missed +
                   ". A stage before it writes a field it does not declare (Stage::accesses), or "
                   "declares a write on_demand / step_local and breaks that promise.");
}

// A Δt limit is not a failed trial of the noise: the step runs again with the same attempt
// number, so the stages draw the numbers they would have drawn had the step been taken at the
// limited Δt from the start (the same bits as a run whose Δt was already that small), and the
// limiter's own answer depends only on the state, so the retry is reproducible bit for bit.
void Simulation::retry_limited(const RollbackRequest& req, double dt) {
  ++stats_.dt_limits;
  ++stats_.step_dt_limits;
  if (dt_->limit_to(req.outcome.dt_limit)) return;
  std::ostringstream os;
  os << "step " << state_->step << ": stage '" << graph_->nodes()[req.node].id << "' limits Δt to "
     << req.outcome.dt_limit << " (" << req.outcome.reason << "), below dt_min = " << dt_->min()
     << " (the step was tried at Δt = " << dt << ")";
  if (!req.outcome.particles.empty()) {
    os << "; particles involved:";
    for (std::size_t k = 0; k < req.outcome.particles.size() && k < 8; ++k) os << " " << req.outcome.particles[k];
  }
  os << ". Lower run.dt_min, or look for particles that came (nearly) on top of each other.";
  throw RunError(os.str());
}

void Simulation::advance() {
  if (!observed_initial_) {
    // Frame 0: observers see the initial configuration.
    observe(dt_->dt());
    observed_initial_ = true;
  }
  // A decomposed team migrates particles or refreshes its ghosts here, before the snapshot: a
  // rollback never undoes either.
  if (domain_) domain_->begin_step(*state_);
  const std::uint64_t step = state_->step;
  stats_.step_rollbacks = 0;
  stats_.step_dt_limits = 0;
  std::unique_ptr<StateImage> before;
  if (options_.check_rollbacks && snapshot_) {
    before = std::make_unique<StateImage>();
    before->take(*state_, step_local_fields());
  }
  if (snapshot_) snapshot_->take(*state_, scheduler_->main_stream());
  // A stage may leave reading its results past this step when nothing looks at the step before
  // the next one starts (StepContext::may_defer_past_step); alone only.
  const bool may_end_pending = deferred_reads_ && !domain_ && !in_team(options_.team) && !observer_due(step + 1);
  scheduler_->set_step_may_end_pending(may_end_pending);
  pending_possible_ = pending_possible_ || may_end_pending;
  for (std::uint32_t attempt = 0;;) {
    const double dt = dt_->dt();
    auto req = scheduler_->run_compute(step, attempt, dt, state_->time);
    if (!req) {
      stats_.dt = dt;
      stats_.dt_limit = scheduler_->reported_dt_limit();
      state_->time += dt;
      state_->step = step + 1;
      dt_->accepted(dt, stats_.dt_limit, attempt > 0);
      break;
    }
    restore_for_retry(*req, before.get(), step, attempt);
    if (req->limits_dt()) {
      retry_limited(*req, dt);  // the same attempt: see retry_limited
    } else {
      ++stats_.rollbacks;
      ++stats_.step_rollbacks;
      if (req->node >= 0) {
        ++rollbacks_asked_[std::size_t(req->node)];
        last_rollback_reason_[std::size_t(req->node)] = req->outcome.reason;
      }
      if (!dt_->halve()) give_up(*req, dt);
      ++attempt;
    }
  }
  // Observers see this step's metrics: a read left pending by a stage that did not run in this
  // step is settled first.
  if (observer_due(state_->step)) settle_pending();
  if (domain_) reduce_metrics();
  for (int i : graph_->compute_nodes())
    if (slots_[i].ran) collect_metrics(i);
  observe(stats_.dt);
}

void Simulation::synchronize() {
  scheduler_->synchronize();
  settle_pending();
}

void Simulation::settle_pending() {
  if (!pending_possible_) return;
  pending_possible_ = false;
  scheduler_->settle_pending();
  for (int i : graph_->compute_nodes())
    if (slots_[i].ran) collect_metrics(i);
}

std::vector<std::string> Simulation::rollback_sources() const {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < rollbacks_asked_.size(); ++i)
    if (rollbacks_asked_[i])
      out.push_back("step '" + graph_->nodes()[i].id + "' asked for " + std::to_string(rollbacks_asked_[i]) +
                    (last_rollback_reason_[i].empty() ? "" : " (the last: " + last_rollback_reason_[i] + ")"));
  return out;
}

const RunStats& Simulation::stats() const {
  const_cast<Simulation*>(this)->settle_pending();  // (the metrics a stage reads back late)
  return stats_;
}

// A decomposed team's compute stages measured their own particles: every rank takes the sum
// (Metrics::set_sum) or the largest value over the ranks, so rank 0 reports what one rank alone
// would. Every rank has the same metrics (the same stages ran and set them).
void Simulation::reduce_metrics() {
  std::vector<double> sums, maxima;
  for (int i : graph_->compute_nodes()) {
    if (!slots_[i].ran) continue;
    const Metrics& m = slots_[i].metrics;
    for (auto& [name, value] : m.values()) (m.is_sum(name) ? sums : maxima).push_back(value);
  }
  double shape[2] = {double(sums.size()) + 1e6 * double(maxima.size()),
                     -(double(sums.size()) + 1e6 * double(maxima.size()))};
  options_.team->all_reduce(shape, 2, ReduceOp::max);
  if (shape[0] != -shape[1])
    throw RunError("step " + std::to_string(state_->step) +
                   ": the ranks of a decomposed team report different metrics (a stage sets a metric on some "
                   "ranks only)");
  if (!sums.empty()) options_.team->all_reduce(sums.data(), sums.size(), ReduceOp::sum);
  if (!maxima.empty()) options_.team->all_reduce(maxima.data(), maxima.size(), ReduceOp::max);
  std::size_t a = 0, b = 0;
  for (int i : graph_->compute_nodes()) {
    if (!slots_[i].ran) continue;
    Metrics& m = slots_[i].metrics;
    const Metrics measured = m;
    for (auto& [name, value] : measured.values()) {
      if (measured.is_sum(name)) m.set_sum(name, sums[a++]);
      else m.set(name, maxima[b++]);
    }
  }
}

void Simulation::run() {
  try {
    while (state_->step < spec_.run.steps) advance();
    if (!observed_initial_) {
      observe(dt_->dt());
      observed_initial_ = true;
    }
    synchronize();
  } catch (...) {
    try {
      finish(false);
    } catch (...) {
    }
    throw;
  }
  finish(true);
}

void Simulation::finish(bool completed) {
  if (finished_) return;
  finished_ = true;
  if (completed) synchronize();
  std::exception_ptr first;
  // Stages without files first: observe.progress ends its terminal line before the observers
  // with files report what an unfinished run kept.
  for (bool with_files : {false, true})
    for (std::size_t i = 0; i < slots_.size(); ++i) {
      auto& s = slots_[i];
      if (s.stage->outputs().empty() == with_files) continue;
      try {
        // Rank 0's observers in a decomposed team finish on the state they observed.
        s.stage->finish(gathered_ && graph_->nodes()[i].observer ? *gathered_ : *state_, completed);
      } catch (...) {
        if (!first) first = std::current_exception();
      }
    }
  if (first) std::rethrow_exception(first);
}

}  // namespace ff
