// The Delaunay pipelines on a decomposed team (issue 21 item 2; docs/multi-gpu.md "The Delaunay
// pipelines"): each rank triangulates its slab's particles, its ghosts and fixed vertices beyond
// the band, on the CPU thread team.
//
// - Bits: pipelines/hard-disks.yaml (Brownian hard disks at η = 0.5, overlap correction on the
//   Delaunay edges) at a Δt that makes the detection roll steps back, and pipelines/abp.yaml
//   (active Brownian particles at φ = 0.4, clustering), in double and float, give on 2 and 4
//   ranks (and pipelines/bench-abp.yaml, φ = 0.7 from a lattice sample, on 4 ranks), gathered
//   by particle id, the position, image, orientation and position_prev of one
//   rank alone after 1000 steps, the same rollbacks, Δt and overlap-correction metrics, with
//   migrations and particles changing owner on the way (counted).
// - Ghost completeness along the run: every 100 steps every rank's star of every owned particle,
//   as global ids in cyclic order, equals that particle's star in the triangulation alone.
// - Local rebuilds: some rank rebuilt its triangulation where it broke only in elements without
//   an owned vertex (near the band's outer edge), without a rollback (counted, in the hard-disk
//   run: otherwise the test would not show that they leave the bits alone).
// - A band too narrow for the triangles near the slab stops the run naming the parameter; a band
//   close to that grows (the domain's band at the end is wider than configured) and the bits
//   still equal one rank's.
// - With 2 or more GPUs (NCCL; skipped visibly otherwise): hard disks and ABP on 2 and 4 GPUs
//   give one GPU's bits (written without a machine to run it: the host parts of the team path
//   copy the fields they read, docs/multi-gpu.md).
// - `pipeline run pipelines/hard-disks.yaml --gpus 4 --device cpu` writes the positions, images,
//   rollbacks, Δt and correction metrics of the run alone into trajectory.h5, and its gr.csv.
// - Refusals: delaunay.flip's substep mode, an observer that reads the triangulation.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "core/backend/comm.h"
#include "core/backend/device.h"
#include "core/base/error.h"
#include "core/run/domain.h"
#include "core/run/simulation.h"
#include "core/run/team.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/slab.h"
#include "support/cli.h"
#include "support/fields.h"
#include "support/pipeline.h"
#include "support/one_gpu_team.h"
#include "support/team.h"

using namespace ff;
using ff::test::bytes_of;

namespace {

using Stars = std::map<std::uint32_t, std::vector<std::uint32_t>>;  // particle id -> star as ids

// The stars of the owned particles of `s` (all of them alone) as global ids.
Stars owned_stars(State& s) {
  Field& he = s.field(delaunay::fields::halfedge);
  Field& ve = s.field(delaunay::fields::vertex_edge);
  he.acquire(Where::host, Mode::read);
  ve.acquire(Where::host, Mode::read);
  const std::uint32_t* id = nullptr;
  if (s.has_field(fields::particle_id)) {
    s.field(fields::particle_id).acquire(Where::host, Mode::read);
    id = s.field(fields::particle_id).host<std::uint32_t>();
  }
  Stars out;
  for (std::size_t v = 0; v < s.n_owned(); ++v)
    out[id ? id[v] : std::uint32_t(v)] = delaunay::star(he.host<std::int32_t>(), ve.host<std::int32_t>(), int(v), id);
  return out;
}

struct End {
  std::map<std::string, std::vector<unsigned char>> fields;  // the whole system, by particle id
  std::map<std::string, double> metrics;                      // the last step's (rank 0: reduced)
  std::uint64_t rollbacks = 0, step = 0, migrations = 0, changed_owner = 0;
  double dt = 0, time = 0, band = 0;
  double local_rebuilds = 0;                 // summed over the steps (rank 0's reduced metric)
  std::map<std::uint64_t, Stars> stars;      // alone: every particle's star every `every` steps
  std::vector<std::string> failures;         // team: owned stars that differ from alone's
  std::size_t stars_compared = 0;
};

// `steps` steps on `ranks` ranks (1: alone). Every `every` steps the owned stars are recorded
// (alone) or compared with `alone`'s.
// one_gpu: a CUDA team of `ranks` on GPU 0 (support/one_gpu_team.h).
End run(const test::LoadedPipeline& l, int ranks, std::uint64_t steps, std::uint64_t every, const End* alone = nullptr,
        Backend backend = Backend::cpu, bool one_gpu = false) {
  End end;
  std::mutex m;
  auto body = [&](Communicator* comm) {
    const auto simulation = test::rank_simulation(l, backend, comm);
    Simulation& sim = *simulation;
    for (std::uint64_t i = 1; i <= steps; ++i) {
      sim.advance();
      if (!comm || comm->rank() == 0) {
        auto it = sim.stats().metrics.find("delaunay.detect_inversion/local_rebuilds");
        if (it != sim.stats().metrics.end()) end.local_rebuilds += it->second;
        it = sim.stats().metrics.find("delaunay.flip/local_rebuilds");
        if (it != sim.stats().metrics.end()) end.local_rebuilds += it->second;
      }
      if (i % every) continue;
      Stars mine = owned_stars(sim.state());
      std::lock_guard<std::mutex> hold(m);
      if (!alone) {
        end.stars[i] = std::move(mine);
        continue;
      }
      const Stars& ref = alone->stars.at(i);
      for (auto& [id, star] : mine) {
        ++end.stars_compared;
        if (star != ref.at(id) && end.failures.size() < 5)
          end.failures.push_back("step " + std::to_string(i) + ", rank " + std::to_string(comm ? comm->rank() : 0) +
                                 ": the star of particle " + std::to_string(id) + " differs from the one alone");
      }
    }
    sim.gather();
    std::lock_guard<std::mutex> hold(m);
    if (sim.domain()) {
      end.migrations = sim.domain()->migrations();
      end.changed_owner += sim.domain()->changed_owner();
      end.band = sim.domain()->band();
    }
    if (comm && comm->rank() != 0) return;
    State& whole = sim.gathered_state() ? *sim.gathered_state() : sim.state();
    for (auto& f : whole.particle_field_names()) end.fields[f] = bytes_of(whole, f);
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

// What must equal one rank's: every particle field (position, image, type, diameter,
// orientation, position_prev), the clock, the rollbacks and the integrator's and the
// correction's metrics. The topology stages' metrics count a rank's own flips and are not
// compared (a rank's maximum, not one rank's count).
void check_same(const End& team, const End& alone) {
  for (auto& f : team.failures) FAIL_CHECK(f);
  CHECK(team.failures.empty());
  CHECK(team.stars_compared > 0);
  CHECK(team.migrations >= 2);
  CHECK(team.changed_owner >= 1);
  CHECK(team.rollbacks == alone.rollbacks);
  CHECK(team.step == alone.step);
  CHECK(team.dt == alone.dt);
  CHECK(team.time == alone.time);
  CHECK(alone.fields.count("position"));
  CHECK(alone.fields.count(delaunay::fields::position_prev));
  CHECK(team.fields.size() == alone.fields.size());
  for (auto& [name, bytes] : alone.fields) {
    INFO("field " << name);
    REQUIRE(team.fields.count(name));
    CHECK(team.fields.at(name) == bytes);
  }
  for (auto& [name, value] : alone.metrics) {
    if (name.rfind("overlap_correct/", 0) != 0) continue;
    INFO("metric " << name);
    REQUIRE(team.metrics.count(name));
    CHECK(team.metrics.at(name) == value);
  }
}

test::LoadedPipeline pipeline(const char* file, std::vector<std::string> set) {
  return test::load_compute_steps(test::repo_file(file).string(), set);
}

}  // namespace

TEST_CASE("decomposed Delaunay: hard disks with rollbacks on 2 and 4 ranks give one rank's bits and stars") {
  // N = 1024 at η = 0.5 (box 40 σ; on 4 ranks slabs of 10 σ with a band of 12.5 σ), Δt = 0.03:
  // moves of up to ~0.7 σ, so steps roll back and overlaps are deep.
  auto l = pipeline("pipelines/hard-disks.yaml", {"system.N=1024", "run.dt=0.03"});
  const End alone = run(l, 1, 1000, 100);
  CHECK(alone.rollbacks >= 3);
  CHECK(alone.metrics.at("overlap_correct/iterations") > 0);
  double local_rebuilds = 0;
  for (int ranks : {2, 4}) {
    INFO(ranks << " ranks, hard disks");
    const End team = run(l, ranks, 1000, 100, &alone);
    check_same(team, alone);
    local_rebuilds += team.local_rebuilds;
  }
  CHECK(local_rebuilds >= 1);
}

TEST_CASE("decomposed Delaunay: ABP on 2 and 4 ranks, double and float, give one rank's bits and stars") {
  for (const char* precision : {"double", "float"}) {
    auto l = pipeline("pipelines/abp.yaml", {"system.N=1024", std::string("run.precision=") + precision});
    const End alone = run(l, 1, 1000, 100);
    CHECK(alone.fields.count("orientation"));
    for (int ranks : {2, 4}) {
      INFO(ranks << " ranks, ABP, " << precision);
      check_same(run(l, ranks, 1000, 100, &alone), alone);
    }
  }
  // pipelines/bench-abp.yaml: φ = 0.7 from a lattice sample, dense clusters (motility-induced).
  auto l = pipeline("pipelines/bench-abp.yaml", {"system.N=1024"});
  const End alone = run(l, 1, 1000, 100);
  INFO("4 ranks, bench-abp.yaml");
  check_same(run(l, 4, 1000, 100, &alone), alone);
}

TEST_CASE("decomposed Delaunay: the band grows when the triangles near a slab do, and stops the run when too narrow") {
  // A dilute ABP gas (φ = 0.1: mean spacing 2.8 σ, voids of several spacings). A band of 4
  // spacings cannot hold the first triangulation's largest circumdisks twice over: the run
  // stops naming the parameter.
  {
    auto l = pipeline("pipelines/abp.yaml", {"system.N=1024", "system.packing_fraction=0.1",
                                             "step.delaunay.detect_inversion.band=11"});
    Team team = make_team(Backend::cpu, 2);
    CHECK_THROWS_WITH(run_team(team,
                               [&](Communicator& comm) {
                                 auto sim = test::rank_simulation(l, Backend::cpu, &comm);
                                 for (int i = 0; i < 5; ++i) sim->advance();
                               }),
                      Catch::Contains("raise delaunay.detect_inversion's band"));
  }
  // With a band just wide enough at the start, the domain widens it while the run goes (a
  // migration each time) and the bits stay one rank's.
  auto l = pipeline("pipelines/abp.yaml", {"system.N=1024", "system.packing_fraction=0.1",
                                           "step.delaunay.detect_inversion.band=28"});
  const End alone = run(l, 1, 600, 100);
  const End team = run(l, 2, 600, 100, &alone);
  check_same(team, alone);
  CHECK(team.band > 28);
}

TEST_CASE("decomposed Delaunay: pipeline run pipelines/hard-disks.yaml --gpus 4 --device cpu writes one rank's outputs") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("flipflow-decomp-delaunay-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string common = test::pipeline_exe() + " run " + test::repo_file("pipelines/hard-disks.yaml").string() +
                             " --device cpu --set system.N=1024 --set run.steps=1000 --set run.dt=0.03"
                             " --set step.observe.gr.from_step=0 --set step.observe.h5md.every=250";
  auto run_cli = [&](const std::string& args) {
    const auto r = test::require_success(test::run_command(common + " " + args, dir / "log.txt"));
    return r.out;
  };
  run_cli("--out " + (dir / "alone").string());
  const std::string team_out = run_cli("--gpus 4 --out " + (dir / "team").string());
  CHECK(team_out.find("a team of 4 ranks") != std::string::npos);
  // The team path is slower than one rank (host work every step): the run says so.
  CHECK(team_out.find("not yet faster than one rank") != std::string::npos);
  // The datasets that must match: the particles and the metrics that are not a rank's own counts.
  auto hashes = [&](const std::string& which) {
    const auto r = test::require_success(test::dataset_hashes(dir / which / "trajectory.h5", dir / "hash.txt"));
    std::istringstream in(r.out);
    std::string line, kept;
    for (; std::getline(in, line);)
      for (const char* path : {"/particles/", "/observables/overlap_correct/", "/observables/rollbacks/", "/observables/dt/"})
        if (line.find(path) != std::string::npos) kept += line + "\n";
    return kept;
  };
  const std::string alone = hashes("alone"), team = hashes("team");
  CHECK(alone.find("/particles/all/position/value") != std::string::npos);
  CHECK(alone == team);
  auto text = [&](const fs::path& p) {
    std::ifstream in(p);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  CHECK(text(dir / "alone" / "gr.csv").size() > 100);
  CHECK(text(dir / "alone" / "gr.csv") == text(dir / "team" / "gr.csv"));
  fs::remove_all(dir);
}

TEST_CASE("decomposed Delaunay: what does not run in a team is refused naming it") {
  {
    auto l = pipeline("pipelines/hard-disks.yaml", {"system.N=1024", "step.delaunay.flip.on_unrepairable=substep"});
    Team team = make_team(Backend::cpu, 2);
    CHECK_THROWS_WITH(run_team(team, [&](Communicator& comm) { test::rank_simulation(l, Backend::cpu, &comm); }),
                      Catch::Contains("substep") && Catch::Contains("team"));
  }
  // pipelines/brownian-delaunay.yaml: delaunay.check compares the triangulation with CGAL's of
  // the whole state; a rank's triangulation is its own.
  {
    const auto log = std::filesystem::temp_directory_path() / ("flipflow-decomp-delaunay-" + std::to_string(::getpid()) + ".txt");
    const auto out = std::filesystem::temp_directory_path() / ("flipflow-decomp-delaunay-out-" + std::to_string(::getpid()));
    const auto r = test::run_command(test::pipeline_exe() + " run " +
                                         test::repo_file("pipelines/brownian-delaunay.yaml").string() +
                                         " --device cpu --gpus 2 --set system.N=1024 --set run.steps=1 --out " +
                                         out.string(),
                                     log);
    std::filesystem::remove(log);
    std::filesystem::remove_all(out);
    INFO(r.out);
    CHECK(r.code == 2);
    CHECK(r.out.find("delaunay.check") != std::string::npos);
    CHECK(r.out.find("drop it or run on one GPU") != std::string::npos);
  }
}

TEST_CASE("decomposed Delaunay: 2 and 4 GPUs give one GPU's bits (hard disks, ABP)") {
  for (int ranks : test::gpu_team_sizes()) {
    struct Case {
      const char* file;
      const char* dt;
    };
    for (const Case& c : {Case{"pipelines/hard-disks.yaml", "run.dt=0.03"}, Case{"pipelines/abp.yaml", "run.dt=0.01"}}) {
      INFO(ranks << " GPUs, " << c.file);
      auto l = pipeline(c.file, {"system.N=1024", c.dt});
      const End alone = run(l, 1, 1000, 100, nullptr, Backend::cuda);
      check_same(run(l, ranks, 1000, 100, &alone, Backend::cuda), alone);
    }
  }
}

TEST_CASE("decomposed Delaunay: 2 ranks on one GPU give its bits (the CUDA team path; hard disks, ABP)") {
  // support/one_gpu_team.h: the CUDA team path where NCCL cannot make a team (one GPU). The
  // correction's team loop runs on the host and refreshes from there; detect_inversion refreshes
  // what the integrator moved on the device (core/run/domain.cpp: refresh sends from the side
  // that is current).
  if (cuda_device_count() < 1) {
    WARN("SKIPPED: no CUDA device");
    return;
  }
  struct Case {
    const char* file;
    const char* dt;
  };
  for (const Case& c : {Case{"pipelines/hard-disks.yaml", "run.dt=0.03"}, Case{"pipelines/abp.yaml", "run.dt=0.01"}}) {
    INFO("2 ranks on one GPU, " << c.file);
    auto l = pipeline(c.file, {"system.N=1024", c.dt});
    const End alone = run(l, 1, 1000, 100, nullptr, Backend::cuda);
    check_same(run(l, 2, 1000, 100, &alone, Backend::cuda, true), alone);
  }
}
