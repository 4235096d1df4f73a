// Decomposed teams (issue 21 items 2-3; core/run/domain.h, docs/multi-gpu.md): each rank holds
// the particles of its slab along x plus ghosts, on the CPU thread team (1, 2, 4 ranks).
//
// - Bits: a Verlet-list pipeline (tests/data/decomp-lj.yaml: neighbors.verlet, pair.lj,
//   overdamped.integrate with max_step) on 2 and 4 ranks gives, gathered by particle id, every
//   particle field one rank alone has after 400 steps (position, image, force, energy, virial,
//   row lengths), in double and float, with list rebuilds, migrations and rollbacks on the way
//   (each counted, so a run in which none happened would fail).
// - Ghost completeness: every owned particle's Verlet row, as global ids, equals the row of the
//   same particle alone (entry for entry, so also in the same order).
// - Rollback agreement: the max_step rollbacks (requested on the rank that owns the fast
//   particle) are taken by every rank: the team's count equals the count alone.
// - neighbors.verlet's ghost_margin (docs/multi-gpu.md, "Migrations"): both ways (0: a migration
//   at every list rebuild; a margin: migrations of their own, the list rebuilt on alone's steps
//   and kept across migrations) give alone's bits and rebuild steps; the hard spheres migrate
//   at least 10x less often with the default margin; a list built when every particle has used
//   98 % of the margin (testing.drift, tests/data/decomp-drift.yaml) lists the pairs that cross
//   the slab boundaries at the band's edge, as alone.
// - Refusals naming the stage: a stage that cannot run on a slab (delaunay.dt_bound), a stage that
//   reads ghosts after another wrote them in the step.
// - `pipeline run --gpus N --device cpu`: rank 0's H5MD file equals the file of a run alone.
// - With 2 or more GPUs (NCCL; skipped visibly otherwise): 2 and 4 GPUs give one GPU's bits.
// - With one GPU: 2 and 3 ranks on it (support/one_gpu_team.h: the CUDA team path, exchanges
//   through the host) give its bits, so the CUDA path is tested where NCCL cannot make a team.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "core/backend/comm.h"
#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/run/simulation.h"
#include "core/run/team.h"
#include "stages/neighbors/list.h"
#include "support/cli.h"
#include "support/fields.h"
#include "support/pipeline.h"
#include "support/one_gpu_team.h"
#include "support/team.h"

using namespace ff;
using ff::test::bytes_of;

namespace {

// Particle fields not compared between a team and one rank: the list builder's per-rank scratch.
const char* const kLocal[] = {"neighbors.order", "neighbors.cell", "neighbors.position_at_build"};

using Rows = std::vector<std::vector<std::uint32_t>>;  // by particle id: its Verlet row as ids

struct End {
  std::map<std::string, std::vector<unsigned char>> fields;  // the whole system, by particle id
  std::map<std::string, double> metrics;                      // the last step's (rank 0: reduced)
  std::uint64_t rollbacks = 0, step = 0, migrations = 0, changed_owner = 0;
  double dt = 0, time = 0;
  Rows rows;                       // alone: every particle's row
  std::vector<std::string> failures;  // team: owned rows that differ from `alone`
  std::vector<std::uint64_t> rebuild_steps;  // the steps on which neighbors.verlet rebuilt the list
  double in_step_rebuilds = 0;  // overlap_correct.verlet's list_rebuilds, summed over the steps
};

// The Verlet rows of the owned particles of `s` as global ids, keyed by id.
std::map<std::uint32_t, std::vector<std::uint32_t>> owned_rows(State& s) {
  Field& list = s.field(neighbors::kList);
  Field& count = s.field(neighbors::kCount);
  list.acquire(Where::host, Mode::read);
  count.acquire(Where::host, Mode::read);
  const std::uint32_t cap = neighbors::list_capacity(s);
  const bool has_id = s.has_field(fields::particle_id);
  // (On CUDA a migration on the device leaves only the device copy of the ids current.)
  if (has_id) s.field(fields::particle_id).acquire(Where::host, Mode::read);
  const std::uint32_t* id = has_id ? s.field(fields::particle_id).host<std::uint32_t>() : nullptr;
  std::map<std::uint32_t, std::vector<std::uint32_t>> out;
  for (std::size_t i = 0; i < s.n_owned(); ++i) {
    auto& row = out[id ? id[i] : std::uint32_t(i)];
    for (std::uint32_t k = 0; k < count.host<std::uint32_t>()[i]; ++k) {
      const std::uint32_t j = list.host<std::uint32_t>()[i * cap + k];
      row.push_back(id ? id[j] : j);
    }
  }
  return out;
}

// `steps` steps on `ranks` ranks (1: alone, no team). With `alone` given, every rank checks its
// owned rows against it. one_gpu: a CUDA team of `ranks` on GPU 0 (support/one_gpu_team.h).
End run(const test::LoadedPipeline& l, int ranks, std::uint64_t steps, const End* alone = nullptr,
        Backend backend = Backend::cpu, bool one_gpu = false) {
  End end;
  std::mutex m;
  auto body = [&](Communicator* comm) {
    const auto simulation = test::rank_simulation(l, backend, comm);
    Simulation& sim = *simulation;
    const bool first = !comm || comm->rank() == 0;
    for (std::uint64_t i = 0; i < steps; ++i) {
      const std::uint64_t step = sim.state().step;
      sim.advance();
      const auto rebuilt = sim.stats().metrics.find("neighbors.verlet/rebuilds");
      if (first && rebuilt != sim.stats().metrics.end() && rebuilt->second != 0) end.rebuild_steps.push_back(step);
      const auto in_step = sim.stats().metrics.find("overlap_correct.verlet/list_rebuilds");
      if (first && in_step != sim.stats().metrics.end()) end.in_step_rebuilds += in_step->second;
    }
    const auto rows = owned_rows(sim.state());
    sim.gather();
    std::lock_guard<std::mutex> hold(m);
    if (sim.domain()) {
      end.migrations = sim.domain()->migrations();  // the same on every rank
      end.changed_owner += sim.domain()->changed_owner();
    }
    if (alone) {
      for (auto& [id, row] : rows)
        if (row != alone->rows[id]) {
          end.failures.push_back("rank " + std::to_string(comm ? comm->rank() : 0) + ": the row of particle " +
                                 std::to_string(id) + " has " + std::to_string(row.size()) + " entries, alone " +
                                 std::to_string(alone->rows[id].size()));
          if (end.failures.size() > 5) break;
        }
    } else if (!comm) {
      end.rows.resize(sim.state().n());
      for (auto& [id, row] : rows) end.rows[id] = row;
    }
    if (comm && comm->rank() != 0) return;
    State& whole = sim.gathered_state() ? *sim.gathered_state() : sim.state();
    for (auto& f : whole.particle_field_names())
      if (std::find(std::begin(kLocal), std::end(kLocal), f) == std::end(kLocal)) end.fields[f] = bytes_of(whole, f);
    end.metrics = sim.stats().metrics;
    end.rollbacks = sim.stats().rollbacks;
    end.dt = sim.stats().dt;
    end.step = sim.state().step;
    end.time = sim.state().time;
    sim.finish(true);
  };
  test::on_team(backend, ranks, one_gpu, body);
  return end;
}

// The team ended as `alone` did: every particle field, bit for bit, and the metrics.
void check_same(const End& team, const End& alone, const std::set<std::string>& not_compared = {},
                std::uint64_t min_migrations = 3) {
  for (auto& f : team.failures) FAIL_CHECK(f);
  CHECK(team.failures.empty());
  CHECK(team.migrations >= min_migrations);
  if (min_migrations > 0) CHECK(team.changed_owner >= 1);  // particles crossed slab boundaries
  // The list was rebuilt on alone's steps (with a ghost margin; else on every migration).
  if (!not_compared.count("neighbors.verlet/rebuilds")) CHECK(team.rebuild_steps == alone.rebuild_steps);
  CHECK(team.rollbacks == alone.rollbacks);
  CHECK(team.step == alone.step);
  CHECK(team.dt == alone.dt);
  CHECK(team.time == alone.time);
  CHECK(alone.fields.count("position"));
  CHECK(team.fields.size() == alone.fields.size());
  for (auto& [name, bytes] : alone.fields) {
    if (not_compared.count(name)) continue;
    INFO("field " << name);
    REQUIRE(team.fields.count(name));
    CHECK(team.fields.at(name) == bytes);
  }
  for (auto& [name, value] : alone.metrics) {
    if (not_compared.count(name)) continue;
    INFO("metric " << name);
    REQUIRE(team.metrics.count(name));
    CHECK(team.metrics.at(name) == value);
  }
}

// decomp-lj.yaml with neighbors.verlet's ghost_margin `margin`: 0, ghosts within cutoff + skin and a
// migration at every list rebuild; a small one (0.02: migrations as often, a list kept or
// rebuilt between them on its own); the default (0.3) migrates a few times in 400 steps only.
test::LoadedPipeline lj(const std::string& precision, std::vector<std::string> more = {},
                        const std::string& margin = "0.02") {
  more.push_back("run.precision=" + precision);
  more.push_back("step.neighbors.verlet.ghost_margin=" + margin);
  return test::load_compute_steps(test::repo_file("tests/data/decomp-lj.yaml").string(), more);
}

}  // namespace

TEST_CASE("decomposition: 2 and 4 CPU ranks give one rank's bits, rows and rollbacks after 400 steps") {
  // Both ways of neighbors.verlet in a team: ghost_margin 0 (a migration at every rebuild) and a
  // margin (migrations of their own; the list rebuilt on alone's steps by the team's test, and
  // kept across a migration by making its rows again from the positions at its build).
  for (const char* margin : {"0", "0.02"})
    for (const char* precision : {"double", "float"}) {
      auto l = lj(precision, {}, margin);
      const End alone = run(l, 1, 400);
      // The run must exercise what it tests: rollbacks (max_step) and several list rebuilds.
      CHECK(alone.rollbacks >= 1);
      CHECK(alone.rebuild_steps.size() >= 5);
      for (int ranks : {2, 4}) {
        INFO(ranks << " ranks, " << precision << ", ghost_margin " << margin);
        check_same(run(l, ranks, 400, &alone), alone);
      }
    }
}

TEST_CASE("decomposition: 2D on 3 ranks, and 3D on 12 ranks, whose slabs are narrower than the band") {
  // 12 slabs of 1.27 σ in a box of 15.2 σ with a band of 1.8 σ: ghosts come from ranks two slabs
  // away. 2D: a box of 72 σ cut in 3. Double.
  struct Case {
    std::vector<std::string> set;
    int ranks;
  };
  for (const Case& c : {Case{{"system.dimensions=2", "run.seed=5"}, 3}, Case{{}, 12}}) {
    auto l = lj("double", c.set);
    const End alone = run(l, 1, 300);
    INFO(c.ranks << " ranks" << (c.set.empty() ? ", 3D" : ", 2D"));
    check_same(run(l, c.ranks, 300, &alone), alone);
  }
}

TEST_CASE("decomposition: phoretic short range with harmonic contacts, and pipelines/harmonic.yaml as shipped") {
  // The phoretic velocities (drift: velocity+force), the harmonic forces and their `pairs` metric
  // (summed over the ranks: a pair across two ranks is counted once) equal one rank's.
  {
    auto l = test::load_compute_steps(test::repo_file("tests/data/decomp-phoretic-short.yaml").string(),
                                      {"step.neighbors.verlet.ghost_margin=0.02"});  // migrations: several
    const End alone = run(l, 1, 300);
    CHECK(alone.rollbacks >= 1);
    CHECK(alone.metrics.at("harmonic.forces/pairs") > 0);
    for (int ranks : {2, 4}) {
      INFO(ranks << " ranks, phoretic short range");
      check_same(run(l, ranks, 300, &alone), alone);
    }
  }
  {
    auto l = test::load_compute_steps(test::repo_file("pipelines/harmonic.yaml").string(), {"system.N=1024"});
    const End alone = run(l, 1, 200);
    INFO("3 ranks, pipelines/harmonic.yaml");
    check_same(run(l, 3, 200, &alone), alone);
  }
}

TEST_CASE("decomposition: delaunay.sort sorts the whole state before the split (pipelines/lj-aggregation.yaml)") {
  // The sort renumbers the particles at configure time, before the domain numbers them: the team
  // and one rank alone number them alike.
  auto l = test::load_compute_steps(test::repo_file("pipelines/lj-aggregation.yaml").string(), {"system.N=512"});
  const End alone = run(l, 1, 200);
  INFO("2 ranks, pipelines/lj-aggregation.yaml");
  check_same(run(l, 2, 200, &alone), alone, {}, 0);
}

TEST_CASE("decomposition: hard spheres (overlap_correct.verlet) on 2 and 4 ranks") {
  // The correction iterates with its pair counts summed over the ranks and the moved positions
  // sent to the ghosts after every iteration. With ghost_margin 0 the team migrates, and so
  // rebuilds the list, at skin/4 where one rank alone rebuilds at skin/2, also within the step:
  // the row lengths and the rebuild counts differ, nothing else may (the pushes are fixed-point
  // sums over the overlapping pairs, which every list holds). With the default margin the team
  // keeps alone's list (rows, rebuilds, max_neighbors, the correction's own rebuilds): all equal.
  const std::string yaml = test::repo_file("tests/data/decomp-hard-spheres.yaml").string();
  const std::set<std::string> rebuild_timing = {"neighbors.count", "neighbors.verlet/rebuilds",
                                                "neighbors.verlet/max_neighbors", "overlap_correct.verlet/list_rebuilds"};
  for (const bool margin : {false, true}) {
    auto l = test::load_compute_steps(yaml, margin ? std::vector<std::string>{}
                                                   : std::vector<std::string>{"step.neighbors.verlet.ghost_margin=0"});
    const End alone = run(l, 1, 300);
    CHECK(alone.metrics.at("overlap_correct.verlet/pairs") > 0);
    for (int ranks : {2, 4}) {
      INFO(ranks << " ranks, hard spheres, " << (margin ? "the default ghost_margin" : "ghost_margin 0"));
      if (margin) check_same(run(l, ranks, 300, &alone), alone, {}, 1);
      else check_same(run(l, ranks, 300), alone, rebuild_timing);  // rows: another rebuild timing
    }
  }
}

TEST_CASE("decomposition: hard spheres whose pushes make the list due within the step (skin 0.1)") {
  // With skin 0.1 the correction's pushes take a particle past skin/2 since the build on ~9 % of
  // the steps: alone rebuilds the list within the step and corrects again. With the default
  // ghost_margin the team does the same from the particles it holds (the band condition holds:
  // band 1.8, cutoff + skin + 2δ with δ ≤ 0.325 + the pushes) and gives alone's bits, rows and
  // in-step rebuilds; with ghost_margin 0 it cannot, and stops naming the margin.
  const std::string yaml = test::repo_file("tests/data/decomp-hard-spheres.yaml").string();
  auto l = test::load_compute_steps(yaml, {"step.neighbors.verlet.skin=0.1"});
  const End alone = run(l, 1, 300);
  CHECK(alone.in_step_rebuilds >= 5);
  for (int ranks : {2, 4}) {
    INFO(ranks << " ranks");
    const End team = run(l, ranks, 300, &alone);
    check_same(team, alone, {}, 1);
    CHECK(team.in_step_rebuilds == alone.in_step_rebuilds);
  }
  auto l0 = test::load_compute_steps(yaml, {"step.neighbors.verlet.skin=0.1", "step.neighbors.verlet.ghost_margin=0"});
  try {
    run(l0, 2, 300);
    FAIL("a team without a ghost margin rebuilt the list within the step");
  } catch (const RunError& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find("overlap_correct.verlet") != std::string::npos);
    CHECK(std::string(e.what()).find("ghost_margin") != std::string::npos);
  }
}

TEST_CASE("decomposition: neighbors.verlet's ghost margin makes the hard spheres migrate less often") {
  // tests/data/decomp-hard-spheres.yaml on 2 ranks: with ghost_margin 0 the team migrates once a
  // particle moved skin/4 = 0.075 σ (most steps); with the default margin (0.3 σ) at 0.375 σ.
  auto migrations = [](const std::string& margin) {
    auto l = test::load_compute_steps(test::repo_file("tests/data/decomp-hard-spheres.yaml").string(),
                                      {"system.N=4096", "step.neighbors.verlet.ghost_margin=" + margin});
    return run(l, 2, 200).migrations;
  };
  const std::uint64_t before = migrations("0"), after = migrations("0.3");
  INFO("migrations in 200 steps: ghost_margin 0: " << before << ", 0.3: " << after);
  CHECK(before >= 50);
  CHECK(after * 10 <= before);
}

TEST_CASE("decomposition: a list built when particles used 98 % of the ghost margin is alone's") {
  // tests/data/decomp-drift.yaml (testing.drift: known displacements): particles 0 and 1, and 2
  // and 3, come within cutoff + skin of each other across slab boundaries for the first time at
  // the build of step 42, when every particle is 0.462 from where it was at the last migration
  // (the margin allows 0.47), particle 1 0.025 inside rank 0's band; the team migrates on step 43,
  // where the list is not due and keeps its rows. On 2 and 4 ranks, after steps 0-42 and 0-59:
  // every owned row and the rebuild steps equal alone's, and the pairs are listed.
  auto l = test::load_compute_steps(test::repo_file("tests/data/decomp-drift.yaml").string(), {}, {"testing"});
  for (const std::uint64_t steps : {43, 60}) {
    const End alone = run(l, 1, steps);
    REQUIRE(alone.rows.size() >= 4);
    auto listed = [&](std::uint32_t a, std::uint32_t b) {
      return std::find(alone.rows[a].begin(), alone.rows[a].end(), b) != alone.rows[a].end();
    };
    CHECK(listed(0, 1));
    CHECK(listed(2, 3));
    CHECK(alone.rebuild_steps == std::vector<std::uint64_t>(
                                     steps == 43 ? std::initializer_list<std::uint64_t>{0, 14, 28, 42}
                                                 : std::initializer_list<std::uint64_t>{0, 14, 28, 42, 56}));
    for (int ranks : {2, 4}) {
      INFO(ranks << " ranks, " << steps << " steps");
      const End team = run(l, ranks, steps, &alone);
      check_same(team, alone, {}, 0);
      CHECK(team.migrations == (steps == 43 ? 0u : 1u));
    }
  }
}

namespace {

// The steps of a team run (rank 0's view) on which the team migrated, and those on which it
// migrated and rolled back.
struct MigrationSteps {
  std::vector<std::uint64_t> migrated, migrated_and_rolled_back;
};

MigrationSteps migration_steps(const test::LoadedPipeline& l, int ranks, std::uint64_t steps) {
  MigrationSteps out;
  Team team = make_team(Backend::cpu, ranks);
  run_team(team, [&](Communicator& comm) {
    const auto simulation = test::rank_simulation(l, Backend::cpu, &comm);
    Simulation& sim = *simulation;
    for (std::uint64_t i = 0; i < steps; ++i) {
      const std::uint64_t step = sim.state().step, before = sim.domain()->migrations();
      sim.advance();
      if (comm.rank() != 0 || sim.domain()->migrations() == before) continue;
      out.migrated.push_back(step);
      if (sim.stats().step_rollbacks > 0) out.migrated_and_rolled_back.push_back(step);
    }
    sim.finish(true);
  });
  return out;
}

}  // namespace

TEST_CASE("decomposition: a rollback requested on one rank on a migration step is taken by every rank") {
  // testing.rollback scrambles the positions of the rank it runs on and requests a rollback, on
  // the steps where the team migrates (so the attempt it undoes rebuilt the list for the new
  // particles: the retry must rebuild it again, not take the restored list of the old ones).
  // Every rank must roll back, and the run must equal one rank alone that requests the same.
  const std::string yaml = test::repo_file("tests/data/decomp-lj-agreement.yaml").string();
  auto load = [&](int rank, const std::string& steps) {
    return test::load_compute_steps(yaml, {"step.ask_rollback.rank=" + std::to_string(rank),
                                           "step.ask_rollback.steps=" + steps,
                                           "step.neighbors.verlet.ghost_margin=0.02"}, {"testing"});
  };
  const MigrationSteps found = migration_steps(load(-1, "[]"), 2, 400);
  REQUIRE(found.migrated.size() >= 4);
  std::string steps = "[";
  for (std::size_t k = 0; k < 8 && k < found.migrated.size(); ++k) steps += (k ? ", " : "") + std::to_string(found.migrated[k]);
  steps += "]";
  INFO("rollbacks requested on steps " << steps);
  const End alone = run(load(0, steps), 1, 400);
  for (int ranks : {2, 4}) {
    INFO(ranks << " ranks, requests on rank " << ranks - 1);
    auto l = load(ranks - 1, steps);
    // (The rollbacks halve Δt, so the particles move less and the team migrates less often.)
    check_same(run(l, ranks, 400, &alone), alone, {}, 2);
    if (ranks == 2) CHECK(!migration_steps(l, 2, 400).migrated_and_rolled_back.empty());
  }
}

TEST_CASE("decomposition: a stage that cannot run on a slab, or reads stale ghosts, is refused by name") {
  // pipelines/brownian-points-dt-bound.yaml: delaunay.dt_bound (a Δt limit from every particle's
  // nearest neighbour) does not run on a slab; refused by name, the Delaunay stages that do not
  // named. (delaunay.sort, refused here before, sorts the whole state at configure time, before
  // the particles are split: it runs; the Delaunay pipelines run decomposed:
  // tests/test_decomposition_delaunay.cpp.)
  {
    auto l = test::load_compute_steps(test::repo_file("pipelines/brownian-points-dt-bound.yaml").string(),
                                      {"system.N=256"});
    try {
      run(l, 2, 1);
      FAIL("a decomposed team ran delaunay.dt_bound");
    } catch (const InputError& e) {
      const std::string m = e.what();
      INFO(m);
      CHECK(m.find("'delaunay.dt_bound'") != std::string::npos);
      CHECK(m.find("cannot run on a rank's share") != std::string::npos);
      for (const char* id : {"'delaunay.detect_inversion'", "'delaunay.flip'", "'delaunay.lawson'", "'delaunay.sort'"})
        CHECK(m.find(id) == std::string::npos);
    }
  }
  // The integrator before the list (as pipelines/hard-spheres.yaml orders them): the list would
  // read ghosts that hold the positions of the start of the step.
  {
    const std::string yaml = test::repo_file("tests/data/decomp-lj.yaml").string();
    auto doc_text = [&] {
      std::ifstream in(yaml);
      std::string t((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      return t;
    }();
    const std::string moved = "  - {stage: overdamped.integrate, D: 1, mobility: 1, max_step: 0.1}\n";
    const auto at = doc_text.find(moved);
    REQUIRE(at != std::string::npos);
    doc_text.erase(at, moved.size());
    doc_text.insert(doc_text.find("  - {stage: neighbors.verlet"), moved);
    const auto path = std::filesystem::temp_directory_path() / ("flipflow-decomp-" + std::to_string(::getpid()) + ".yaml");
    {
      std::ofstream out(path);
      out << doc_text;
    }
    auto l = test::load_compute_steps(path.string(), {});
    std::filesystem::remove(path);
    try {
      run(l, 2, 1);
      FAIL("a decomposed team let a stage read ghosts written earlier in the step");
    } catch (const InputError& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find("step 'neighbors.verlet' reads the ghosts' `position`") != std::string::npos);
      CHECK(std::string(e.what()).find("'overdamped.integrate'") != std::string::npos);
    }
  }
}

TEST_CASE("decomposition: pipeline run --gpus N --device cpu writes one rank's H5MD file") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("flipflow-decomp-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string exe = test::pipeline_exe();
  const std::string common = exe + " run " + test::repo_file("tests/data/decomp-lj.yaml").string() +
                             " --device cpu --set run.steps=200 --set system.N=500";
  auto run_cli = [&](const std::string& args) {
    const auto r = test::require_success(test::run_command(common + " " + args, dir / "log.txt"));
    return r.out;
  };
  run_cli("--out " + (dir / "alone").string());
  const std::string out = run_cli("--gpus 3 --out " + (dir / "team").string());
  CHECK(out.find("a team of 3 ranks") != std::string::npos);
  CHECK(out.find("not yet faster") == std::string::npos);  // (the Delaunay team's warning, not the Verlet team's)
  auto hashes = [&](const std::string& which) {
    const auto r = test::require_success(test::dataset_hashes(dir / which / "decomp-lj.h5", dir / "hash.txt"));
    return r.out;
  };
  const std::string alone = hashes("alone"), team = hashes("team");
  CHECK(alone.find("/particles/all/position/value") != std::string::npos);
  CHECK(alone == team);
  fs::remove_all(dir);
}

TEST_CASE("decomposition: 2 and 4 GPUs give one GPU's bits (Lennard-Jones, hard spheres)") {
  for (int ranks : test::gpu_team_sizes()) {
    for (const char* precision : {"double", "float"}) {
      INFO(ranks << " GPUs, Lennard-Jones, " << precision);
      auto l = lj(precision);
      const End alone = run(l, 1, 400, nullptr, Backend::cuda);
      check_same(run(l, ranks, 400, &alone, Backend::cuda), alone);
    }
    INFO(ranks << " GPUs, hard spheres");
    auto l = test::load_compute_steps(test::repo_file("tests/data/decomp-hard-spheres.yaml").string(), {});
    const End alone = run(l, 1, 300, nullptr, Backend::cuda);
    // The default ghost_margin: the team keeps alone's list, so everything is compared (6
    // migrations in 300 steps on the CPU).
    check_same(run(l, ranks, 300, nullptr, Backend::cuda), alone, {}, 1);
  }
}

TEST_CASE("decomposition: 2 and 3 ranks on one GPU give its bits (the CUDA team path; Lennard-Jones, hard spheres)") {
  // NCCL puts one rank on a GPU; these ranks share GPU 0 and exchange through the host, and run
  // everything else as a team of GPUs does. The hard spheres' correction refreshes its ghosts
  // within its step; on the first run on 2 GPUs (session 20) it stopped at max_iterations on
  // step 52: each refresh packed the host copy of the positions, current as of the refresh
  // before, and uploaded it over the iteration's moves. That happens on one GPU as well.
  if (cuda_device_count() < 1) {
    WARN("SKIPPED: no CUDA device");
    return;
  }
  auto lj_double = lj("double");
  auto hs = test::load_compute_steps(test::repo_file("tests/data/decomp-hard-spheres.yaml").string(), {});
  const End lj_alone = run(lj_double, 1, 400, nullptr, Backend::cuda);
  const End hs_alone = run(hs, 1, 300, nullptr, Backend::cuda);
  CHECK(hs_alone.metrics.at("overlap_correct.verlet/pairs") > 0);
  CHECK(hs_alone.metrics.count("overlap_correct.verlet/iterations"));
  for (int ranks : {2, 3}) {
    {
      INFO(ranks << " ranks on one GPU, Lennard-Jones");
      check_same(run(lj_double, ranks, 400, &lj_alone, Backend::cuda, true), lj_alone);
    }
    INFO(ranks << " ranks on one GPU, hard spheres");
    check_same(run(hs, ranks, 300, nullptr, Backend::cuda, true), hs_alone, {}, 1);  // the default ghost_margin
  }
}
