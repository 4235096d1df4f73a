// overlap_correct on CPU and CUDA: the same bits in double and agreement in float; the same bits on
// every device path (for a run alone without walls or the touched field, dense_block.cuh: one
// block up to 1 024 particles, a cluster of up to 16 blocks up to 16 384; otherwise the team's
// thread-block cluster for n ≤ kClusterMaxN, its last iterations in block 0's shared memory for a
// run of up to ~4 100 particles, the whole grid above), when
// runs share the GPU (smaller teams), over many steps of ABP (lists kept across steps), where
// max_iterations stops a step on the grid path (the wide kernels decide on the device), and over
// a correction longer than one run of the device's held sums. Each skips without a CUDA device.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "core/backend/device.h"
#include "core/base/error.h"
#include "stages/overlap_correct/test_support.h"
#include "support/backends.h"
#include "support/cli.h"
#include "support/pipeline.h"

using namespace ff;
using namespace ff::overlap_test;

namespace {

// One step of `spec` from its initial state jiggled by `amplitude` on backend b: the positions
// after it and the step's iteration and pair counts and summed correction.
struct OneStep {
  std::vector<double> xy;
  double iterations = 0, pairs = 0, correction = 0;
};
OneStep one_step(const PipelineSpec& spec, Backend b, double amplitude = 0.1) {
  auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
  jiggle(*state, amplitude, 5);
  Simulation sim(spec, registry(), dry(b), std::move(state));
  sim.advance();
  sim.synchronize();
  return {positions(sim.state()), metric(sim, "iterations"), metric(sim, "pairs"), metric(sim, "correction")};
}

}  // namespace

TEST_CASE("overlap_correct: CPU and CUDA give the same bits (double) and agree in float", "[overlap][cuda]") {
  // 1000: the dense block (dense_block.cuh); 3000: the dense cluster of 12 blocks of 256 particles,
  // 12000 of 12 blocks of 1 024; 20000: the grid.
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA")) return;
  for (std::uint64_t n : {1000u, 3000u, 12000u, 20000u}) {
    for (Precision p : {Precision::f64, Precision::f32})
      for (const char* mode : {"reflect", "contact"}) {
        INFO(n << " " << to_string(p) << " " << mode);
        const auto spec = correct_spec(n, 0.75, {{"mode", std::string(mode)}}, p);
        const OneStep cpu = one_step(spec, Backend::cpu), cuda = one_step(spec, Backend::cuda);
        const std::vector<std::vector<double>> xy{cpu.xy, cuda.xy};
        CHECK(cpu.iterations == cuda.iterations);
        if (p == Precision::f64) {
          CHECK(std::memcmp(xy[0].data(), xy[1].data(), xy[0].size() * sizeof(double)) == 0);
        } else {
          double worst = 0;
          for (std::size_t i = 0; i < xy[0].size(); ++i) worst = std::max(worst, std::fabs(xy[0][i] - xy[1][i]));
          INFO("largest float difference " << worst);
          CHECK(worst <= 1e-4);
        }
      }
  }
}

// One correction of n disks at area fraction 0.75 on each backend (`mark: true` with the touched
// field): the same iterations, pairs and position bits (a correction of at least 3 iterations, so
// the device loop really iterates).
static void check_cpu_equals_cuda(std::uint64_t n, bool mark = false) {
  const auto spec = mark ? correct_spec(n, 0.75, {{"mark", true}}) : correct_spec(n, 0.75, {});
  const OneStep cpu = one_step(spec, Backend::cpu), cuda = one_step(spec, Backend::cuda);
  const std::vector<std::vector<double>> xy{cpu.xy, cuda.xy};
  CHECK(cpu.iterations >= 3);
  CHECK(cpu.iterations == cuda.iterations);
  CHECK(cpu.pairs == cuda.pairs);
  CHECK(std::memcmp(xy[0].data(), xy[1].data(), xy[0].size() * sizeof(double)) == 0);
}

TEST_CASE("overlap_correct: CPU and CUDA give the same bits on either device path (team and grid)",
          "[overlap][cuda]") {
  // cuda.cu runs a run alone without the touched field (mark: false) of up to 1 024 particles in
  // one block (dense_block.cuh: 1000), of up to 16 384 in a dense cluster of up to 16 blocks holding
  // 256 particles each (2048, 2100: 9 blocks, the last holding 52; 4096), 512 (5000, 8192) or 1 024
  // (8193: 9 blocks, the last holding one; 16384). With the touched field, small systems (n ≤
  // kClusterMaxN = 8192) run in the team's thread-block cluster, the last iterations of a run of up
  // to ~4 100 particles (double, sm_90) in block 0's shared memory (shared_tail.cuh; 2100: the
  // cluster's blocks of at most 144 particles, two passes of lane groups). Larger ones run on the
  // whole grid (20000 is the grid's); 150000 fills it (more particles than its threads on a GPU of up
  // to ~290 SMs), so its first iteration runs in the wide kernels (DeviceLoops::prepare).
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA by size")) return;
  for (std::uint64_t n : {1000u, 2048u, 2100u, 4096u, 5000u, 8192u, 8193u, 16384u, 65536u, 150000u}) {
    INFO("n " << n);
    check_cpu_equals_cuda(n);
  }
  for (std::uint64_t n : {2100u, 4096u, 5000u, 8192u}) {
    INFO("n " << n << ", mark: true");
    check_cpu_equals_cuda(n, true);
  }
}

TEST_CASE("overlap_correct: CPU and CUDA give the same bits when runs share the GPU (smaller teams)",
          "[overlap][cuda]") {
  // On a GPU that many runs share (runs_sharing_gpu, `pipeline sweep`), team_for gives a run the
  // cluster of 8 blocks (kSharedClusterBlocks) where a run alone takes the grid and K grids would
  // not fit on the GPU (an H100/H200's 132 SMs: a shared grid of 16384 holds 32 SMs, of 65536 all
  // 132; with 2 runs 16384 keeps the grid; 3000 takes the cluster of 16 whether shared or not).
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA with shared GPUs")) return;
  for (int sharing : {64, 2}) {
    ff::set_runs_sharing_gpu(sharing);
    for (std::uint64_t n : {3000u, 16384u, 65536u}) {
      INFO("runs sharing the GPU " << sharing << ", n " << n);
      check_cpu_equals_cuda(n);
    }
  }
  ff::set_runs_sharing_gpu(1);
}

// Many steps of ABP at φ = 0.7 (abp.yaml's stages: integrate, Delaunay maintenance with flips
// every step, overlap_correct). On the grid path (20000, 100000) the device keeps each particle's
// fan from one step to the next where the flips left it alone (neighbor_lists.cuh, kept_fan) and
// runs the late iterations of a step in one block; 600 and 1000 run in the dense block and 2000 in
// the dense cluster (dense_block.cuh), crossings of the box included. None may change a bit.
// Positions, image counts and each step's iterations, pairs and summed correction must equal the
// CPU's.
TEST_CASE("overlap_correct: CPU and CUDA give the same bits over many steps of ABP (kept fans)",
          "[overlap][cuda]") {
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA over many steps")) return;
  for (std::uint64_t n : {600u, 1000u, 2000u, 20000u, 100000u}) {
    INFO("n " << n);
    const auto l = test::load_compute_steps(
        test::repo_file("pipelines/abp.yaml").string(),
        {"system.N=" + std::to_string(n), "system.packing_fraction=0.7", "system.init=triangular_lattice_sample",
         "run.steps=150"});
    struct Run {
      std::vector<double> xy, iterations, pairs, correction;
      std::vector<std::int32_t> image;
    };
    auto run = [&](Backend b) {
      Simulation sim(l.spec, *l.registry, dry(b));
      Run r;
      for (std::uint64_t k = 0; k < l.spec.run.steps; ++k) {
        sim.advance();
        r.iterations.push_back(metric(sim, "iterations"));
        r.pairs.push_back(metric(sim, "pairs"));
        r.correction.push_back(metric(sim, "correction"));
      }
      sim.synchronize();
      r.xy = positions(sim.state());
      Field& img = sim.state().field(fields::image);
      img.acquire(Where::host, Mode::read);
      r.image.assign(img.host<std::int32_t>(), img.host<std::int32_t>() + 2 * n);
      return r;
    };
    const Run cpu = run(Backend::cpu), cuda = run(Backend::cuda);
    double most = 0;
    for (double it : cpu.iterations) most = std::max(most, it);
    CHECK(most >= 5);  // the late iterations do run (on the grid path, in block 0's tail)
    CHECK(cpu.iterations == cuda.iterations);
    CHECK(cpu.pairs == cuda.pairs);
    CHECK(cpu.correction == cuda.correction);
    CHECK(cpu.image == cuda.image);
    CHECK(std::memcmp(cpu.xy.data(), cuda.xy.data(), cpu.xy.size() * sizeof(double)) == 0);
  }
}

TEST_CASE("overlap_correct: CPU and CUDA stop alike at max_iterations on the grid path", "[overlap][cuda]") {
  // On a full grid the first iterations run in cuda.cu's wide kernels, which decide on the device
  // whether an iteration goes on (keeps_going: also k < max_iterations) and the cooperative kernel
  // after them replays that decision. Stopping at iteration 1, 2 or 3 of a step: the same error on
  // both backends, whose count of pairs still overlapping (the last gather's) and worst pair depend
  // on exactly which iterations were applied. 20000 disks: the cooperative kernel alone; 150000:
  // more than the grid's threads on a GPU of up to ~290 SMs at one block of 512 an SM, so the wide
  // kernels first (DeviceLoops::prepare). 1000 and 3000: the dense block and cluster, which decide
  // each iteration on the device too.
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA at max_iterations")) return;
  for (std::uint64_t n : {1000u, 3000u, 20000u, 150000u})
  for (std::int64_t most : {1, 2, 3}) {
    INFO("n " << n << ", max_iterations " << most);
    const auto spec = correct_spec(n, 0.8, {{"max_iterations", most}});
    std::string message[2];
    for (int b = 0; b < 2; ++b) {
      auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
      jiggle(*state, 0.1, 11);
      Simulation sim(spec, registry(), dry(b == 0 ? Backend::cpu : Backend::cuda), std::move(state));
      try {
        sim.advance();
        sim.synchronize();
      } catch (const RunError& e) {
        message[b] = e.what();
      }
    }
    INFO("cpu: " << message[0]);
    INFO("cuda: " << message[1]);
    CHECK(message[0].find("max_iterations = " + std::to_string(most)) != std::string::npos);
    CHECK(message[0] == message[1]);
  }
}

TEST_CASE("overlap_correct: CPU and CUDA stop alike at max_iterations in a step's last iterations",
          "[overlap][cuda]") {
  // A step's last iterations move few particles: the device runs them in block 0 alone, from
  // shared memory for a run of up to ~4 100 particles (shared_tail.cuh: 3000, 4096), from global
  // memory after the cluster (5000) and after the grid (20000); a run alone without the touched
  // field of up to 16 384 particles runs every iteration in the dense block (1000) or cluster
  // (3000, 12000), so the team's tails are reached here with `mark: true`. A lattice at η = 0.8
  // jiggled by 0.3σ (~38 iterations) stopped two iterations before its step would end: the same
  // error on both backends (pairs still overlapping, the worst pair).
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA at max_iterations in the tail")) return;
  const std::pair<std::uint64_t, bool> cases[] = {{1000u, false}, {3000u, false}, {12000u, false}, {20000u, false},
                                                  {3000u, true},  {4096u, true},  {5000u, true}};
  for (const auto& [n, mark] : cases) {
    const std::int64_t needs = std::int64_t(one_step(correct_spec(n, 0.8, {}), Backend::cpu, 0.3).iterations);
    INFO("n " << n << ", mark " << mark << ", iterations " << needs);
    REQUIRE(needs >= 8);
    const auto spec = correct_spec(n, 0.8, {{"max_iterations", needs - 2}, {"mark", mark}});
    std::string message[2];
    for (int b = 0; b < 2; ++b) {
      try {
        one_step(spec, b == 0 ? Backend::cpu : Backend::cuda, 0.3);
      } catch (const RunError& e) {
        message[b] = e.what();
      }
    }
    INFO("cpu: " << message[0]);
    INFO("cuda: " << message[1]);
    CHECK(message[0].find("max_iterations = " + std::to_string(needs - 2)) != std::string::npos);
    CHECK(message[0] == message[1]);
  }
}

TEST_CASE("overlap_correct: CPU and CUDA agree on a correction longer than one run of held sums",
          "[overlap][cuda]") {
  // The device kernels keep each iteration's sums in shared memory and store them to the host's
  // pinned memory 32 iterations at a time (correct_kernel.cuh and dense_block.cuh, kRowsHeld); the
  // host replays the step from them (its iterations, pairs and summed correction). A lattice at
  // η = 0.8 jiggled by 0.3σ takes ~38 iterations on the CPU: more than one run, in the dense block
  // (1000) and cluster (3000, 5000), on the team's cluster with its tail in shared memory (3000,
  // mark: true) and in global memory (5000, mark: true), the grid and the wide path (150000: its
  // first iterations in the wide kernels).
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA over more than 32 iterations")) return;
  const std::pair<std::uint64_t, bool> cases[] = {{1000u, false}, {3000u, false}, {5000u, false}, {20000u, false},
                                                  {150000u, false}, {3000u, true}, {5000u, true}};
  for (const auto& [n, mark] : cases) {
    INFO("n " << n << ", mark " << mark);
    const auto spec = correct_spec(n, 0.8, {{"mark", mark}});
    const OneStep cpu = one_step(spec, Backend::cpu, 0.3), cuda = one_step(spec, Backend::cuda, 0.3);
    INFO("iterations " << cpu.iterations);
    CHECK(cpu.iterations > 32);
    CHECK(cpu.iterations == cuda.iterations);
    CHECK(cpu.pairs == cuda.pairs);
    CHECK(cpu.correction == cuda.correction);
    CHECK(std::memcmp(cpu.xy.data(), cuda.xy.data(), cpu.xy.size() * sizeof(double)) == 0);
  }
}
