// The integrators in a CUDA graph: a pipeline whose compute stages are all graph-capturable is
// captured once and replayed every step (Scheduler::step_is_captured), and the replayed steps give
// the bits of the same pipeline launched directly — so Δt, the step and the attempt reach the
// kernels through StepParams, advanced by the graph, and nothing of the captured step is frozen.
// Free Brownian motion (brownian.yaml's stage), ABP without the Delaunay stages (2D and 3D), and
// overdamped.integrate with a force drift and per-type D and μ. The CUDA cases are skipped, with a
// visible warning, without a GPU; what each stage tells the core is checked everywhere. Steps that
// are never captured read StepParams from slots uploaded ahead (DeviceStepParams): every step
// reads its own values through rollbacks, Δt changes and the end of the slots.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime.h>

#include "core/run/cuda/graph.h"
#endif
#include "core/input/init.h"
#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::dry;
using ff::test::entry;

namespace {

const Registry& registry() {
  static const auto r = test::registry_with({"brownian", "abp", "phoretic"});
  return *r;
}

// Before the run: fields a stage before the integrator would have written (tests only).
using Prepare = std::function<void(State&)>;

std::unique_ptr<State> initial(const PipelineSpec& s, const Prepare& prepare) {
  auto st = make_initial_state(s.system, s.run.precision, s.run.seed);
  if (prepare) prepare(*st);
  return st;
}

// `steps` steps of `s` on CUDA, captured and launched directly; `fields` must agree bit for bit
// and must have changed.
void check_captured_equals_direct(const PipelineSpec& s, const Prepare& prepare, const std::vector<std::string>& fields,
                                  int steps) {
  Simulation captured(s, registry(), dry(Backend::cuda), initial(s, prepare));
  Simulation direct(s, registry(), dry(Backend::cuda), initial(s, prepare));
  direct.scheduler().set_graph_capture(false);
  std::vector<std::vector<unsigned char>> start;
  for (auto& f : fields) start.push_back(test::bytes_of(captured.state(), f));
  for (int k = 0; k < steps; ++k) {
    captured.advance();
    direct.advance();
  }
  CHECK(captured.scheduler().step_is_captured());
  CHECK_FALSE(direct.scheduler().step_is_captured());
  CHECK(captured.state().step == std::uint64_t(steps));
  CHECK(captured.state().time == direct.state().time);
  for (std::size_t k = 0; k < fields.size(); ++k) {
    INFO("field " << fields[k]);
    const auto a = test::bytes_of(captured.state(), fields[k]);
    const auto b = test::bytes_of(direct.state(), fields[k]);
    REQUIRE(a.size() == b.size());
    CHECK(std::memcmp(a.data(), b.data(), a.size()) == 0);
    CHECK(std::memcmp(a.data(), start[k].data(), a.size()) != 0);
  }
}

PipelineSpec abp_spec(int dim) {
  return test::spec(dim, 4096, 0.3, 30, 0.01,
                    {entry(registry(), "abp.integrate", {{"v0", 1.0}, {"Dr", 0.5}, {"D", 0.01}})}, 11);
}

// overdamped.integrate with drift: force, two types with their own D and μ, and a `force` field
// that varies from particle to particle (fixed: no force stage runs).
PipelineSpec force_spec() {
  auto s = test::spec(2, 4096, 0.3, 30, 0.01,
                      {entry(registry(), "overdamped.integrate",
                             {{"drift", std::string("force")},
                              {"D", std::vector<double>{0.2, 0.05}},
                              {"mobility", std::vector<double>{1.0, 0.25}}})},
                      13);
  s.system.types = {{"A", 0.5, 1.0}, {"B", 0.5, 1.0}};
  return s;
}

void add_force(State& s) {
  Field& f = s.add_particle_field("force", s.real(), s.dim());
  f.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double v = std::sin(0.37 * double(i)) * 3.0;
    if (s.precision() == Precision::f64) f.host<double>()[i] = v;
    else f.host<float>()[i] = float(v);
  }
}

}  // namespace

TEST_CASE("the integrators tell the core they are capturable and read StepParams", "[graph]") {
  RunInfo info;
  info.dim = 2;
  for (const char* name : {"overdamped.integrate", "brownian.integrate", "phoretic.integrate", "abp.integrate"}) {
    INFO(name);
    const auto st = registry().create(name, Backend::cpu, ParamValues::defaults(registry().get(name).decl.params), info);
    CHECK(st->scheduling().graph_capturable);
    CHECK(st->scheduling().reads_step_params);
    CHECK_FALSE(st->scheduling().may_request_rollback);
  }
}

TEST_CASE("steps never captured read their own StepParams from the slots uploaded ahead", "[graph][cuda]") {
  if (!test::have_cuda("step parameters uploaded ahead")) return;
#ifdef FLIPFLOW_HAVE_CUDA
  DeviceStepParams dp;
  cudaStream_t stream = nullptr;
  REQUIRE(cudaStreamCreate(&stream) == cudaSuccess);
  auto on_device = [&] {
    StepParams h{};
    REQUIRE(cudaMemcpyAsync(&h, dp.device(), sizeof h, cudaMemcpyDeviceToHost, stream) == cudaSuccess);
    REQUIRE(cudaStreamSynchronize(stream) == cudaSuccess);
    return h;
  };
  auto require_holds = [&](const StepParams& p) {
    const StepParams d = on_device();
    INFO("step " << p.step << " attempt " << p.attempt << " dt " << p.dt << " time " << p.time);
    CHECK(d.step == p.step);
    CHECK(d.attempt == p.attempt);
    CHECK(std::memcmp(&d.dt, &p.dt, sizeof(double)) == 0);
    CHECK(std::memcmp(&d.time, &p.time, sizeof(double)) == 0);
  };
  // A run as Simulation::advance drives it: 3 kAhead steps, a rollback (attempt 1 at half the
  // Δt) at step 40 and at step 90 (a Δt limit: the same attempt again at a smaller Δt), Δt
  // growing back at step 150; time accumulates Δt by the host's additions.
  std::uint64_t step = 5;
  double time = 0.37, dt = 0.01;
  int moves = 0;
  const StepParams* before = nullptr;
  for (int k = 0; k < 3 * DeviceStepParams::kAhead; ++k, ++step) {
    std::uint32_t attempt = 0;
    if (k == 40) {
      dp.set(StepParams{step, attempt, dt, time}, stream, true);
      require_holds(StepParams{step, attempt, dt, time});
      ++attempt;
      dt /= 2;
    }
    if (k == 90) {
      dp.set(StepParams{step, attempt, dt, time}, stream, true);
      require_holds(StepParams{step, attempt, dt, time});
      dt *= 0.75;
    }
    if (k == 150) dt *= 2;
    const StepParams p{step, attempt, dt, time};
    dp.set(p, stream, true);
    if (before && dp.device() == before + 1) ++moves;
    before = dp.device();
    require_holds(p);
    dp.set(p, stream, true);  // the same step again: nothing changes
    CHECK(dp.device() == before);
    time += dt;
  }
  // Most steps moved to the next slot without an upload (each miss restarts at slot 0).
  CHECK(moves >= 3 * DeviceStepParams::kAhead - 12);
  // Without `ahead` the block stays in slot 0, whose address a captured graph holds.
  dp.set(StepParams{step, 0, dt, time}, stream, false);
  const StepParams* slot0 = dp.device();
  dp.set(StepParams{step + 1, 0, dt, time + dt}, stream, false);
  CHECK(dp.device() == slot0);
  require_holds(StepParams{step + 1, 0, dt, time + dt});
  cudaStreamDestroy(stream);
#endif
}

TEST_CASE("a captured CUDA step replays brownian.integrate bit for bit", "[graph][cuda]") {
  if (!test::have_cuda("graph capture of brownian.integrate")) return;
  for (int dim : {2, 3}) {
    INFO(dim << "D");
    const auto s = test::spec(dim, 4096, 0.3, 30, 0.01, {entry(registry(), "brownian.integrate", {{"D", 1.0}})}, 7);
    check_captured_equals_direct(s, nullptr, {fields::position, fields::image}, 30);
  }
}

TEST_CASE("a captured CUDA step replays abp.integrate (no Delaunay stages) bit for bit", "[graph][cuda]") {
  if (!test::have_cuda("graph capture of abp.integrate")) return;
  for (int dim : {2, 3}) {
    INFO(dim << "D");
    check_captured_equals_direct(abp_spec(dim), nullptr, {fields::position, fields::image, "orientation"}, 30);
  }
}

TEST_CASE("a captured CUDA step replays overdamped.integrate with a force drift bit for bit", "[graph][cuda]") {
  if (!test::have_cuda("graph capture of overdamped.integrate with drift: force")) return;
  check_captured_equals_direct(force_spec(), add_force, {fields::position, fields::image}, 30);
}
