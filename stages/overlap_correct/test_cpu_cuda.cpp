// overlap_correct on CPU and CUDA: the same bits in double and agreement in float; the same bits on
// either device path (a thread-block cluster for n ≤ kClusterMaxN, the whole grid above), and when
// runs share the GPU (smaller teams). Each skips without a CUDA device.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/backend/device.h"
#include "stages/overlap_correct/test_support.h"
#include "support/backends.h"

using namespace ff;
using namespace ff::overlap_test;

namespace {

// One step of `spec` from its jiggled initial state on backend b: the positions after it and the
// step's iteration and pair counts.
struct OneStep {
  std::vector<double> xy;
  double iterations = 0, pairs = 0;
};
OneStep one_step(const PipelineSpec& spec, Backend b) {
  auto state = make_initial_state(spec.system, spec.run.precision, spec.run.seed);
  jiggle(*state, 0.1, 5);
  Simulation sim(spec, registry(), dry(b), std::move(state));
  sim.advance();
  sim.synchronize();
  return {positions(sim.state()), metric(sim, "iterations"), metric(sim, "pairs")};
}

}  // namespace

TEST_CASE("overlap_correct: CPU and CUDA give the same bits (double) and agree in float", "[overlap][cuda]") {
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA")) return;
  for (Precision p : {Precision::f64, Precision::f32})
    for (const char* mode : {"reflect", "contact"}) {
      INFO(to_string(p) << " " << mode);
      const auto spec = correct_spec(20000, 0.75, {{"mode", std::string(mode)}}, p);
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

// One correction of n disks at area fraction 0.75 on each backend: the same iterations, pairs and
// position bits (a correction of at least 3 iterations, so the device loop really iterates).
static void check_cpu_equals_cuda(std::uint64_t n) {
  const auto spec = correct_spec(n, 0.75, {});
  const OneStep cpu = one_step(spec, Backend::cpu), cuda = one_step(spec, Backend::cuda);
  const std::vector<std::vector<double>> xy{cpu.xy, cuda.xy};
  CHECK(cpu.iterations >= 3);
  CHECK(cpu.iterations == cuda.iterations);
  CHECK(cpu.pairs == cuda.pairs);
  CHECK(std::memcmp(xy[0].data(), xy[1].data(), xy[0].size() * sizeof(double)) == 0);
}

TEST_CASE("overlap_correct: CPU and CUDA give the same bits on either device path (team and grid)",
          "[overlap][cuda]") {
  // cuda.cu runs small systems (n ≤ kClusterMaxN = 4096) in a thread-block cluster and larger
  // ones on the whole grid: sizes on both sides, and the threshold itself. (20000, the size of the
  // tests above, is the grid's.)
  if (!test::have_cuda("overlap_correct CPU-vs-CUDA by size")) return;
  for (std::uint64_t n : {3000u, 4096u, 65536u, 100000u}) {
    INFO("n " << n);
    check_cpu_equals_cuda(n);
  }
}

TEST_CASE("overlap_correct: CPU and CUDA give the same bits when runs share the GPU (smaller teams)",
          "[overlap][cuda]") {
  // On a GPU that many runs share (runs_sharing_gpu, `pipeline sweep`), team_for gives a run the
  // cluster of 16 blocks where a run alone takes the grid and K grids would not fit on the GPU
  // (an H100/H200's 132 SMs: 16384 holds 32 SMs, 65536 128; with 2 runs 16384 keeps the grid).
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
