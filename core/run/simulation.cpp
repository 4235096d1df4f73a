#include "core/run/simulation.h"

#include <filesystem>
#include <set>
#include <sstream>

#include "core/backend/comm.h"
#include "core/base/error.h"
#include "core/input/init.h"

namespace fs = std::filesystem;

namespace ff {

Simulation::Simulation(const PipelineSpec& spec, const Registry& registry, RunOptions options)
    : Simulation(spec, registry, std::move(options), make_initial_state(spec.system, spec.run.precision, spec.run.seed)) {}

Simulation::Simulation(const PipelineSpec& spec, const Registry& registry, RunOptions options,
                       std::unique_ptr<State> state)
    : spec_(spec), options_(std::move(options)), state_(std::move(state)) {
  build(registry);
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
                        options_.team};
    slot.rng = make_rng_key(spec_.run.seed, e.id.c_str());
    try {
      slot.stage = registry.create(e.stage, options_.backend, e.params, slot.info);
      slot.stage->configure(*state_);
    } catch (const InputError& err) {
      throw InputError(e.where.str() + ": step '" + e.id + "': " + err.what());
    }
    accesses.push_back(slot.stage->accesses());
    for (auto& a : accesses.back())
      if (!state_->has_field(a.field))
        throw InputError(e.where.str() + ": step '" + e.id + "' uses field '" + a.field +
                         "', which no stage before it created");
    observer.push_back(registry.get(e.stage).decl.observer);
  }
  graph_ = std::make_unique<StepGraph>(spec_, std::move(accesses), observer);
  if (in_team(options_.team)) check_team(observer);
  scheduler_ = std::make_unique<Scheduler>(*graph_, slots_, *state_, stats_, options_.backend);
  scheduler_->set_team(options_.team);
  // No rank captures its step into a CUDA graph: a capture on one rank's thread would be broken
  // by another rank's allocations or waits in the same process (as for `pipeline sweep
  // --in-process`). The same bits, launched directly.
  if (in_team(options_.team)) scheduler_->set_graph_capture(false);
  dt_ = std::make_unique<DtController>(spec_.run.dt, spec_.run.dt_min, spec_.run.dt_grow_after);
  stats_.dt = spec_.run.dt;

  make_snapshot();
}

// What a team of ranks can run (RunOptions::team, TeamWork in core/stage/stage.h): every stage
// runs on every rank, redundantly on the replicated state or splitting its work. Refused: a
// compute stage that writes files (each rank would write them), and a pipeline in which no
// stage splits (N ranks would compute the same run N times).
void Simulation::check_team(const std::vector<bool>& observer) const {
  const int ranks = options_.team->size();
  std::string redundant;
  bool splits = false;
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    if (observer[i]) continue;
    const StepEntry& e = spec_.step[i];
    if (!slots_[i].stage->outputs().empty())
      throw InputError(e.where.str() + ": step '" + e.id + "' (" + e.stage + ") writes files, and with " +
                       std::to_string(ranks) + " ranks every rank would write them; run it with one GPU");
    if (slots_[i].stage->scheduling().team == TeamWork::split) splits = true;
    else redundant += (redundant.empty() ? "" : ", ") + e.stage;
  }
  if (!splits)
    throw InputError("no stage of " + spec_.file + " divides its work among " + std::to_string(ranks) +
                     " ranks (" + redundant +
                     " cannot split; they would run the same simulation on every rank): run it on one GPU. Stages "
                     "that split: phoretic.forces with range: long (docs/multi-gpu.md)");
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

std::vector<std::string> Simulation::step_local_fields() const {
  std::set<std::string> local, carried;
  for (int j : graph_->compute_nodes())
    for (auto& a : graph_->nodes()[j].accesses)
      if (writes(a.mode)) (a.step_local ? local : carried).insert(a.field);
  std::vector<std::string> out;
  for (auto& f : local)
    if (!carried.count(f)) out.push_back(f);
  return out;
}

void Simulation::prepare_outputs() {
  std::vector<std::string> outputs;
  for (auto& s : slots_)
    for (auto& o : s.stage->outputs()) outputs.push_back(o);
  if (outputs.empty()) return;
  if (options_.out_dir.empty()) throw InputError("this pipeline writes files but no output directory was given (--out)");
  for (auto& o : outputs) {
    const fs::path p = fs::path(options_.out_dir) / o;
    if (fs::exists(p) && !options_.force && !options_.resume)
      throw InputError("output '" + p.string() + "' exists; use --force to overwrite it or --out to write elsewhere");
  }
  std::error_code ec;
  fs::create_directories(options_.out_dir, ec);
  if (ec) throw InputError("cannot create output directory '" + options_.out_dir + "': " + ec.message());
}

void Simulation::collect_metrics(int node) {
  for (auto& kv : slots_[node].metrics.values()) stats_.metrics[slots_[node].info.stage_id + "/" + kv.first] = kv.second;
}

void Simulation::observe(double dt) {
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
  const std::uint64_t step = state_->step;
  stats_.step_rollbacks = 0;
  stats_.step_dt_limits = 0;
  std::unique_ptr<StateImage> before;
  if (options_.check_rollbacks && snapshot_) {
    before = std::make_unique<StateImage>();
    before->take(*state_, step_local_fields());
  }
  if (snapshot_) snapshot_->take(*state_, scheduler_->main_stream());
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
      if (!dt_->halve()) give_up(*req, dt);
      ++attempt;
    }
  }
  for (int i : graph_->compute_nodes())
    if (slots_[i].ran) collect_metrics(i);
  observe(stats_.dt);
}

void Simulation::run() {
  try {
    while (state_->step < spec_.run.steps) advance();
    if (!observed_initial_) {
      observe(dt_->dt());
      observed_initial_ = true;
    }
    scheduler_->synchronize();
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
  if (completed) scheduler_->synchronize();
  std::exception_ptr first;
  for (auto& s : slots_) {
    try {
      s.stage->finish(*state_, completed);
    } catch (...) {
      if (!first) first = std::current_exception();
    }
  }
  if (first) std::rethrow_exception(first);
}

}  // namespace ff
