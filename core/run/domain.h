// A decomposed team (issue 21 items 2-3, ../shared/specs/seed-gaps.md D4, docs/multi-gpu.md):
// rank r of P owns the particles in slab r along x, [r L/P, (r+1) L/P) as they were at the last
// migration, and holds ghosts, copies of the other ranks' particles within `band` (along x,
// periodic) of that slab. The rank's State holds only those: owned first, then ghosts, each in
// ascending global particle id (the field `particle.id`), with their coordinates in the global
// box, so the minimum image, and so every distance, is computed as by one rank alone.
//
// At the start of every step (before the rollback snapshot is taken, so a rollback never undoes
// a migration):
//  - migration, when some owned particle has moved more than `slack` since the last one (one
//    all-reduce decides it for every rank): every rank sends each of its owned particles, every
//    particle field's entries, to its new owner and to every rank whose band it lies in, and
//    rebuilds its State from what it receives (point-to-point, counts first);
//  - otherwise a ghost refresh: each owner sends the `refreshed` fields of its particles to the
//    ranks that hold them as ghosts (one point-to-point batch), so ghosts hold the values of the
//    start of the step.
// A particle within `band` - 2·slack of an owned one at any time between migrations was within
// `band` of the slab at the last one, so it is held: what a TeamWork::local stage builds from the
// held particles (a Verlet list of radius band) is, for the owned particles, what one rank alone
// builds (the proof and the conditions for bitwise equality: docs/multi-gpu.md). A wider band
// than the stage's radius needs lets the team migrate less often than the stage rebuilds
// (neighbors.verlet's ghost_margin: band cutoff + 2 skin + 2M, slack skin/2 + M).
//
// A pipeline that triangulates (Scheduling::fills_gap, the Delaunay stages) also gets fixed fill
// vertices after the ghosts, on a lattice of spacing `band` in the gap beyond the band, so that
// the rank's triangulation of what it holds has no edge across that gap; they are renewed at
// every migration and never sent. A stage may ask for a wider band (request_band): the next
// begin_step takes the widest request of any rank and migrates with it.
//
// On CUDA the work of every step stays on the device (core/run/cuda/ghost_traffic.h): the
// migration test is a kernel with one flag read back; a refresh packs the records on the device
// by index lists kept there, exchanges them (NCCL) and unpacks them there; a migration of a team
// without fill vertices finds destinations, packs, orders (a radix sort of one key a particle) and
// gathers the fields there too. The Delaunay pipelines' migrations, and gather (observers), pack
// and unpack on the host (the fields acquired there: whole fields copied), their records through
// device staging buffers, as NCCL wants (core/backend/comm.h).
#pragma once
#include <cstddef>
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/backend/comm.h"
#include "core/run/slab.h"
#include "core/stage/stage.h"
#include "core/stage/state.h"

namespace ff {

class Domain final : public GhostExchange {
 public:
  // `state`: the whole state, the same bits on every rank, every stage configured. Adds the
  // particle field `particle.id` (0 .. N-1) and cuts the state down to this rank's particles.
  // band: how far ghosts reach from the slab; slack: how far a particle may move before the
  // next migration (0: never migrate). refreshed: the particle fields sent to ghosts each step.
  // fill_gap (2D): fixed vertices fill the gap beyond the band (Scheduling::fills_gap), after
  // the ghosts, renewed at every migration.
  Domain(Communicator& comm, State& state, double band, double slack, std::vector<std::string> refreshed,
         Backend backend, bool fill_gap = false);
  ~Domain() override;

  // Whether fill vertices close the gap beyond the band: the team triangulates (the Delaunay
  // pipelines, whose team path still does host work every step: docs/multi-gpu.md).
  bool fills_gap() const { return fill_gap_; }

  // Before the step's snapshot: migrate when due, else refresh the ghosts. Every rank calls it.
  void begin_step(State& state);

  // The owners' entries of `fields` to the ranks holding them as ghosts (one point-to-point
  // batch). Every rank calls it; begin_step does for `refreshed`, a stage may within its step.
  void refresh(State& state, const std::vector<std::string>& fields) override;
  // The largest request of any rank takes effect at the next begin_step (a migration).
  void request_band(double band) override { requested_band_ = std::max(requested_band_, band); }

  // The `names` particle fields of every rank's owned particles into `into` (rank 0: the whole
  // state, indexed by particle id; other ranks pass null). Every rank calls it.
  void gather(State& state, State* into, const std::vector<std::string>& names);

  std::uint64_t migrations() const { return migrations_; }
  // Host time in begin_step since construction: in the migrations, and in the other steps (the
  // migration test and the ghost refresh; on CUDA, waiting for the device included). For
  // `pipeline bench --gpus N`.
  double migration_seconds() const { return migration_seconds_; }
  double step_start_seconds() const { return step_start_seconds_; }
  // The host time of the migrations by phase (test, destinations, counts, pack, exchange,
  // rebuild: order / fields / lists), summed over them.
  const std::map<std::string, double>& migration_phase_seconds() const { return migration_phase_seconds_; }
  std::uint64_t changed_owner() const { return changed_owner_; }  // particles, summed over migrations (this rank's sends)
  double band() const override { return band_; }
  double displacement(State& state, const std::string& field) override;
  std::size_t n_held() const { return n_held_; }  // owned and ghosts: the fill vertices come after

  // The slab (rank) that owns a particle at x (along axis 0), and whether a particle at x not
  // owned by rank q lies within the band of q's slab (slab.h, shared with the device).
  int owner_of(double x) const;
  bool ghost_of(int q, double x) const;
  SlabGeometry slab() const { return {L_, ranks_, rank_, band_}; }

 private:
  // The bytes of one particle: every particle field's entry, fields in name order.
  struct Layout {
    std::vector<std::string> names;
    std::vector<std::size_t> offset, size;  // within a record
    std::size_t bytes = 0;
    std::size_t id_offset = 0;
    // The index of field `name` in names (names.size() when absent).
    std::size_t index(const std::string& name) const {
      return std::size_t(std::find(names.begin(), names.end(), name) - names.begin());
    }
  };
  Layout layout_of(const State& s, const std::vector<std::string>& names) const;
  void pack(State& s, const Layout& lay, const std::vector<std::uint32_t>& which, std::vector<unsigned char>& out) const;

  bool due(State& s);
  void lap(const char* phase);  // a migration's phase ends: its host time since the last lap
  bool moved(State& s);  // some owned particle moved more than slack_ since the last migration
  void migrate_on_host(State& s);
  void migrate_on_device(State& s);  // CUDA, no fill vertices: core/run/cuda/ghost_traffic.h
  void start_on_host(State& s);      // x0_ current
  // refresh() on CUDA: packed, exchanged and unpacked on the device (core/run/cuda/ghost_traffic.h).
  void refresh_on_device(State& s, const Layout& lay);
  // Rebuilds the state, owned first, then ghosts, by id, from the particles it keeps (`kept`:
  // indices into the state as it is) and the records of every field of `lay` from the others.
  void rebuild(State& s, const Layout& lay, const std::vector<std::uint32_t>& kept,
               const std::vector<unsigned char>& records);
  void set_lists(State& s);
  void exchange_counts(const std::vector<std::uint64_t>& send, std::vector<std::uint64_t>& recv);
  // comm_.exchange of host buffers: on the CPU directly; on CUDA through device staging buffers
  // (NCCL wants device memory), the receives copied back before it returns.
  void transfer(const std::vector<Communicator::Transfer>& t);
  // On CUDA: bring the device copies of `names` up to date after the host wrote them (a stage
  // holds device pointers across a refresh within its step).
  void to_device(State& s, const std::vector<std::string>& names) const;
  std::vector<double> xs(State& s) const;  // every held particle's x
  std::vector<double> owned_values(State& s, const std::string& field) const;  // real x dim, in double
  // The fill vertices of this rank's gap: x y pairs, columns at most `band` apart strictly
  // inside the gap (x farther than band from the slab), rows at most `band` apart, odd columns
  // shifted half a row (stages/delaunay/common/slab.h's fill_gap, the layout its tests check).
  std::vector<double> fill_points(const State& s) const;

  Communicator& comm_;
  int rank_, ranks_;
  double L_;
  double band_, slack_;
  bool fill_gap_ = false;
  std::size_t n_held_ = 0;
  double requested_band_ = 0;
  std::vector<std::string> refreshed_;
  // The real particle fields no stage had written when the team formed (a force, voronoi.area:
  // the steps compute them): the initial gather gives them NaN, not computed, as observe.h5md
  // writes such a field of a run alone (the distribution here writes every field).
  std::vector<std::string> not_computed_;
  std::vector<std::vector<std::uint32_t>> send_, recv_;  // per peer: local indices (refresh)
  std::vector<double> x0_;                                // owned positions at the last migration
  std::uint64_t migrations_ = 0, changed_owner_ = 0;
  double migration_seconds_ = 0, step_start_seconds_ = 0;
  std::map<std::string, double> migration_phase_seconds_;
  std::chrono::steady_clock::time_point lap_;
  bool timing_ = false;  // in a migration of begin_step (not the constructor's)
  Backend backend_;
  struct Staging;  // CUDA builds: the device buffers transfer() stages through
  std::unique_ptr<Staging> staging_;
  bool x0_on_host_ = true;  // else only on the device (GhostTraffic's start, after migrate_on_device)
};

}  // namespace ff
