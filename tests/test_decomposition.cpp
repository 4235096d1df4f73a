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
#include "support/pipeline.h"
#include "support/one_gpu_team.h"
#include "support/team.h"

using namespace ff;

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
};

std::vector<unsigned char> bytes_of(State& s, const std::string& name) {
  Field& f = s.field(name);
  f.acquire(Where::host, Mode::read);
  const auto* p = static_cast<const unsigned char*>(f.host_raw());
  return {p, p + f.bytes()};
}

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
    for (std::uint64_t i = 0; i < steps; ++i) sim.advance();
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
  CHECK(team.changed_owner >= 1);  // particles crossed slab boundaries
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

test::LoadedPipeline lj(const std::string& precision, std::vector<std::string> more = {}) {
  more.push_back("run.precision=" + precision);
  return test::load_compute_steps(test::repo_file("tests/data/decomp-lj.yaml").string(), more);
}

}  // namespace

TEST_CASE("decomposition: 2 and 4 CPU ranks give one rank's bits, rows and rollbacks after 400 steps") {
  for (const char* precision : {"double", "float"}) {
    auto l = lj(precision);
    const End alone = run(l, 1, 400);
    // The run must exercise what it tests: rollbacks (max_step) and several list rebuilds.
    CHECK(alone.rollbacks >= 1);
    for (int ranks : {2, 4}) {
      INFO(ranks << " ranks, " << precision);
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
    auto l = test::load_compute_steps(test::repo_file("tests/data/decomp-phoretic-short.yaml").string(), {});
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
  // sent to the ghosts after every iteration. The team migrates, and so rebuilds the list, at
  // skin/4 where one rank alone rebuilds at skin/2, also within the step: the row lengths and the
  // rebuild counts differ, nothing else may (the pushes are fixed-point sums over the overlapping
  // pairs, which every list holds).
  auto l = test::load_compute_steps(test::repo_file("tests/data/decomp-hard-spheres.yaml").string(), {});
  const End alone = run(l, 1, 300);
  CHECK(alone.metrics.at("overlap_correct.verlet/pairs") > 0);
  const std::set<std::string> rebuild_timing = {"neighbors.count", "neighbors.verlet/rebuilds",
                                                "neighbors.verlet/max_neighbors", "overlap_correct.verlet/list_rebuilds"};
  for (int ranks : {2, 4}) {
    INFO(ranks << " ranks, hard spheres");
    const End team = run(l, ranks, 300);  // rows: another rebuild timing, compared by check_same's fields only
    check_same(team, alone, rebuild_timing);
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
                                           "step.ask_rollback.steps=" + steps}, {"testing"});
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
    check_same(run(l, ranks, 300, nullptr, Backend::cuda), alone,
               {"neighbors.count", "neighbors.verlet/rebuilds", "neighbors.verlet/max_neighbors",
                "overlap_correct.verlet/list_rebuilds"});
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
    check_same(run(hs, ranks, 300, nullptr, Backend::cuda, true), hs_alone,
               {"neighbors.count", "neighbors.verlet/rebuilds", "neighbors.verlet/max_neighbors",
                "overlap_correct.verlet/list_rebuilds"});
  }
}
