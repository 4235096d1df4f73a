// Simulation in a team of ranks (RunOptions::team): what a team can run, whether it decomposes
// the particles into slabs, and the decomposition's checks of the step's order and its Domain.
// Apart from simulation.cpp, which builds and runs the step.
#include <algorithm>
#include <cstring>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/run/domain.h"
#include "core/run/simulation.h"

namespace ff {

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
                     "that split: phoretic.forces with range: long; a decomposed team needs every compute stage to "
                     "run on a slab of particles: neighbors.verlet, the Verlet-list forces (pair.lj, harmonic.forces, "
                     "phoretic.forces with range: short), overlap_correct.verlet, overdamped.integrate, abp.integrate, "
                     "the Delaunay stages (delaunay.sort, detect_inversion, flip, lawson) and overlap_correct "
                     "(docs/multi-gpu.md)");
}

namespace {

bool decomposable(TeamWork w) { return w == TeamWork::decomposed || w == TeamWork::local; }

// A deep copy (rank 0's whole state for its observers in a decomposed team).
std::unique_ptr<State> clone_state(State& s) {
  auto c = std::make_unique<State>(s.dim(), s.precision(), s.n());
  c->box = s.box;
  c->species = s.species;
  c->species_diameter = s.species_diameter;
  c->step = s.step;
  c->time = s.time;
  for (auto& name : s.field_names()) {
    Field& f = s.field(name);
    Field& g = s.is_particle_field(name) ? c->add_particle_field(name, f.dtype(), f.components())
                                         : c->add_field(name, f.dtype(), f.components(), f.count());
    f.acquire(Where::host, Mode::read);
    g.acquire(Where::host, Mode::write);
    if (f.bytes()) std::memcpy(g.host_raw(), f.host_raw(), f.bytes());
  }
  return c;
}

}  // namespace

// A team in which no stage splits but some run on a slab of particles (TeamWork::decomposed or
// local) is decomposed; then every compute stage must, or the team is refused naming those
// that cannot.
bool Simulation::wants_decomposition(const std::vector<bool>& observer) const {
  std::string cannot;
  bool any = false, splits = false;
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    if (observer[i]) continue;
    const TeamWork w = slots_[i].stage->scheduling().team;
    splits = splits || w == TeamWork::split;
    if (decomposable(w)) any = true;
    else cannot += (cannot.empty() ? "" : ", ") + ("'" + spec_.step[i].id + "' (" + spec_.step[i].stage + ")");
  }
  if (!any || splits) return false;
  if (!cannot.empty())
    throw InputError(spec_.file + ": a team of " + std::to_string(options_.team->size()) +
                     " ranks decomposes the particles into slabs (docs/multi-gpu.md), and step(s) " + cannot +
                     " cannot run on a rank's share of the particles: remove them or run on one GPU");
  return true;
}

void Simulation::decompose(const std::vector<bool>& observer) {
  const std::string where = spec_.file + ": a decomposed team of " + std::to_string(options_.team->size()) + " ranks";
  if (spec_.run.checkpoint)
    throw InputError(where + " writes no checkpoints yet (each rank holds a part of the state): remove run.checkpoint");
  if (options_.resume)
    throw InputError(where + " cannot continue a checkpoint yet (it would restore the whole state into a rank's "
                             "part): resume on one GPU");
  const std::vector<int> compute = graph_->compute_nodes();
  double band = 0, slack = 0, reserve = 0;
  bool fill_gap = false;
  bool requester_before = false;  // a stage that may stop a rank's step (rollback, Δt limit) so far
  // Refreshed on ghosts every step: what decomposed stages write (for their owned particles) and
  // some stage reads of the ghosts (the positions, in the Verlet pipelines: not the forces).
  std::set<std::string> written_owned, ghost_reads, written_by_compute;
  // Particle fields decomposed stages wrote so far in the step and no stage refreshed since,
  // with the stage that wrote them: their ghosts still hold the values of the start of the step.
  std::map<std::string, int> stale;
  for (std::size_t a = 0; a < compute.size(); ++a) {
    const int j = compute[a];
    const StepEntry& e = spec_.step[std::size_t(j)];
    const Scheduling sch = slots_[std::size_t(j)].stage->scheduling();
    const auto& accesses = graph_->nodes()[std::size_t(j)].accesses;
    for (auto& acc : accesses) {
      if (writes(acc.mode)) written_by_compute.insert(acc.field);
      if (!state_->is_particle_field(acc.field)) continue;
      if (sch.team == TeamWork::decomposed && writes(acc.mode)) written_owned.insert(acc.field);
      if (sch.reads_ghosts || sch.team == TeamWork::local) ghost_reads.insert(acc.field);
    }
    reserve = std::max(reserve, sch.ghost_reserve);
    if (sch.team == TeamWork::local && sch.ghost_band > 0) {
      band = std::max(band, sch.ghost_band);
      slack = slack > 0 ? std::min(slack, sch.ghost_slack) : sch.ghost_slack;
    }
    fill_gap = fill_gap || (sch.team == TeamWork::local && sch.fills_gap);
    // A stage that reads ghosts must come before every decomposed stage that writes what it
    // reads (for its owned particles only; a local stage writes every particle the rank holds),
    // unless it, or a stage between, refreshes the ghosts first (Scheduling::refreshes_ghosts).
    if (sch.reads_ghosts || sch.team == TeamWork::local) {
      for (auto& acc : accesses) {
        if (writes(acc.mode) || !state_->is_particle_field(acc.field)) continue;
        auto it = stale.find(acc.field);
        if (it == stale.end()) continue;
        if (sch.refreshes_ghosts) {
          stale.erase(it);
          continue;
        }
        const StepEntry& w = spec_.step[std::size_t(it->second)];
        throw InputError(e.where.str() + ": step '" + e.id + "' reads the ghosts' `" + acc.field + "`, which step '" +
                         w.id + "' writes before it in the step; in a decomposed team ghosts hold the values of the "
                         "start of the step: put '" + e.id + "' before '" + w.id +
                         "' (the same dynamics, one half step apart)");
      }
    }
    // After the ghosts' check: a stage that reads stale ghosts is told that first (the order of
    // the step is wrong), also when it communicates (neighbors.verlet with a ghost_margin).
    if ((sch.communicates || sch.refreshes_ghosts) && requester_before)
      throw InputError(e.where.str() + ": step '" + e.id +
                       "' exchanges with the other ranks of a decomposed team within the step, and a stage before "
                       "it may roll the step back or limit Δt on one rank only (which then skips the rest of its "
                       "step): put '" + e.id + "' before it");
    // A communicating stage agrees on its requests (Scheduling::communicates): every rank stops or none.
    requester_before = requester_before || ((sch.may_request_rollback || sch.may_limit_dt) && !sch.communicates);
    if (sch.team == TeamWork::decomposed)
      for (auto& acc : accesses)
        if (writes(acc.mode) && state_->is_particle_field(acc.field)) stale.emplace(acc.field, j);
  }
  // Rank 0's observers read the whole state gathered from every rank: particle fields only.
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    if (!observer[i]) continue;
    for (auto& acc : slots_[i].stage->accesses())
      if (written_by_compute.count(acc.field) && !state_->is_particle_field(acc.field))
        throw InputError(spec_.step[i].where.str() + ": step '" + spec_.step[i].id + "' (" + spec_.step[i].stage +
                         ") reads `" + acc.field + "`, which each rank of a decomposed team holds for its own "
                         "particles only (not per particle, so it cannot be gathered): drop it or run on one GPU");
  }
  if (options_.team->rank() == 0) {
    gathered_ = clone_state(*state_);
    scheduler_->set_observer_state(gathered_.get());
  }
  std::vector<std::string> refreshed;
  for (auto& f : written_owned)
    if (ghost_reads.count(f)) refreshed.push_back(f);
  if (reserve > 0) {
    if (!(slack > reserve))
      throw InputError(where + ": the stages that move particles after the list was built within a step may move one " +
                       std::to_string(reserve) + ", not less than the list's slack " + std::to_string(slack) +
                       " (skin/2): raise neighbors.verlet's skin");
    slack -= reserve;
  }
  domain_ = std::make_unique<Domain>(*options_.team, *state_, band, slack, refreshed, options_.backend, fill_gap);
  scheduler_->set_ghosts(domain_.get());
}

}  // namespace ff
