// CPU and CUDA give the same bits (issue 15, item 9). The shipped pipelines without long-range
// all-pairs sums run 1000 steps on each backend in double (observers removed, N as shipped);
// every field of the final state must hold the same bytes on both, and every step the same
// metrics, Δt and rollbacks. Where the bits come from: every FF_HD function is evaluated with
// the same IEEE operations on both sides: sin/cos/log are core/physics/math.h's own, not libm's or
// libdevice's, and no translation unit of a loop contracts a·b + c into an fma (the CPU loops
// are built with -ffp-contract=off, the CUDA loops with -fmad=false; phoretic.forces, which keeps
// contraction for its all-pairs kernel, writes its short-range products as math::mul_rn).
//
// Two fields are compared by meaning instead of bytes (both sides are right; see same_state):
//   delaunay.lawson_candidates  a list filled by atomic appends: its order varies from run to
//                               run on either backend; the set of its valid entries is compared;
//   delaunay.status             words 3-4 hold Field::version() of `position`, a count of
//                               acquires for writing (bookkeeping of each backend's copies);
//   neighbors.moved             the Verlet list's rebuild test answered by overdamped.integrate
//                               (stages/neighbors/list.h): published on CUDA only, and word 0
//                               is such a version; not compared (the decisions it carries are,
//                               as the rebuilds metric of every step);
//   delaunay.lawson_candidate_count  written on CUDA only, in steps detect_inversion decides on
//                               the device (StepContext::gate); not compared, nor its metric
//                               decided_on_device (where the decision was taken), which Run
//                               counts apart.
// Without a GPU the CUDA cases are skipped with a visible warning; the CPU cases (math.h's
// accuracy, the comparison itself on two CPU runs) run everywhere.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/physics/math.h"
#include "core/input/pipeline_loader.h"
#include "core/physics/rng.h"
#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/cli.h"
#include "support/fields.h"
#include "support/pipeline.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;

namespace {

constexpr std::uint64_t kSteps = 1000;

// The pipelines compared: every shipped one whose stages are all short-ranged.
const std::vector<std::string>& pipelines() {
  static const std::vector<std::string> p{"abp.yaml", "hard-disks.yaml", "phoretic-c2-short.yaml", "lj-aggregation.yaml"};
  return p;
}

using Loaded = test::LoadedPipeline;

// The shipped pipeline with `steps` steps in `precision`, compute stages only, and `extra` overrides.
Loaded load(const std::string& name, std::uint64_t steps, Precision precision, std::vector<std::string> extra = {}) {
  extra.push_back("run.steps=" + std::to_string(steps));
  extra.push_back(std::string("run.precision=") + (precision == Precision::f32 ? "float" : "double"));
  return test::load_compute_steps(test::repo_file("pipelines/" + name).string(), extra);
}

struct FieldBytes {
  DType dtype;
  int components;
  std::vector<unsigned char> bytes;
};

// What a run leaves: the final state and, per step, the metrics, Δt and rollbacks.
struct Run {
  std::map<std::string, FieldBytes> fields;
  std::vector<std::map<std::string, double>> metrics;
  std::vector<double> dt;
  std::vector<std::uint64_t> rollbacks;
  std::uint64_t decided_on_device = 0;  // steps whose detect_inversion decided on the device (read per step)
  std::uint64_t step = 0;
  double time = 0;
  double box[3] = {0, 0, 0};
};

// per_step false: the stats are read once, at the end (reading them every step has every stage read
// back each step's results before the next one starts: StepContext::may_defer_past_step).
Run run(const Loaded& l, Backend b, bool per_step = true) {
  Simulation sim(l.spec, *l.registry, test::dry(b));
  Run r;
  auto metrics = [&] {
    auto m = sim.stats().metrics;
    for (auto it = m.begin(); it != m.end();) {
      const std::string suffix = "/decided_on_device";
      const std::string& k = it->first;
      if (k.size() > suffix.size() && k.compare(k.size() - suffix.size(), suffix.size(), suffix) == 0) {
        r.decided_on_device += it->second != 0;
        it = m.erase(it);
      } else {
        ++it;
      }
    }
    return m;
  };
  for (std::uint64_t k = 0; k < l.spec.run.steps; ++k) {
    sim.advance();
    if (!per_step) continue;
    r.metrics.push_back(metrics());
    r.dt.push_back(sim.stats().dt);
    r.rollbacks.push_back(sim.stats().rollbacks);
  }
  sim.synchronize();
  if (!per_step) {
    r.metrics.push_back(metrics());
    r.dt.push_back(sim.stats().dt);
    r.rollbacks.push_back(sim.stats().rollbacks);
  }
  State& s = sim.state();
  for (const std::string& name : s.field_names()) {
    const Field& f = s.field(name);
    r.fields[name] = {f.dtype(), f.components(), test::bytes_of(s, name)};
  }
  r.step = s.step;
  r.time = s.time;
  for (int k = 0; k < 3; ++k) r.box[k] = s.box.L[k];
  return r;
}

// Scalar j of a field, printed (for the report of a difference).
std::string scalar(const FieldBytes& f, std::size_t j) {
  std::ostringstream os;
  os.precision(17);
  const unsigned char* p = f.bytes.data() + j * dtype_size(f.dtype);
  auto get = [&](auto v) {
    std::memcpy(&v, p, sizeof v);
    return v;
  };
  switch (f.dtype) {
    case DType::f32: os << get(float()); break;
    case DType::f64: os << get(double()); break;
    case DType::i32: os << get(std::int32_t()); break;
    case DType::u32: os << get(std::uint32_t()); break;
    case DType::i64: os << get(std::int64_t()); break;
    case DType::u64: os << get(std::uint64_t()); break;
    case DType::u8: os << unsigned(get(std::uint8_t())); break;
  }
  return os.str();
}

// "" when a and b hold the same bytes, else how many scalars differ and the first one.
std::string byte_difference(const FieldBytes& a, const FieldBytes& b, std::size_t skip_from = ~std::size_t(0),
                            std::size_t skip_to = 0) {
  if (a.dtype != b.dtype || a.bytes.size() != b.bytes.size()) return "different type or size";
  const std::size_t w = dtype_size(a.dtype), n = a.bytes.size() / w;
  std::size_t count = 0, first = 0;
  for (std::size_t j = 0; j < n; ++j) {
    if (j >= skip_from && j < skip_to) continue;
    if (std::memcmp(a.bytes.data() + j * w, b.bytes.data() + j * w, w) != 0 && count++ == 0) first = j;
  }
  if (count == 0) return "";
  std::ostringstream os;
  os << count << " of " << n << " scalars differ; first at scalar " << first << " (element "
     << first / std::size_t(a.components) << "): " << scalar(a, first) << " vs " << scalar(b, first);
  return os.str();
}

// The number of valid entries of delaunay.lawson_candidates after the last step (the
// detect_inversion metric), or -1 when unknown or when the list overflowed (then which entries
// were kept depends on the order).
long valid_candidates(const Run& r, std::size_t capacity) {
  for (auto& kv : r.metrics.back()) {
    const std::string suffix = "/lawson_candidates";
    if (kv.first.size() > suffix.size() && kv.first.compare(kv.first.size() - suffix.size(), suffix.size(), suffix) == 0)
      return kv.second <= double(capacity) ? long(kv.second) : -1;
  }
  return -1;
}

// Every difference between two runs, one line each ("" when none).
std::string differences(const Run& a, const Run& b) {
  std::ostringstream os;
  if (a.step != b.step || std::memcmp(&a.time, &b.time, sizeof a.time) != 0)
    os << "  clock: step " << a.step << " vs " << b.step << ", time " << a.time << " vs " << b.time << "\n";
  for (std::size_t k = 0; k < a.dt.size() && k < b.dt.size(); ++k)
    if (a.dt[k] != b.dt[k] || a.rollbacks[k] != b.rollbacks[k]) {
      os << "  step " << k << ": dt " << a.dt[k] << " vs " << b.dt[k] << ", rollbacks so far " << a.rollbacks[k]
         << " vs " << b.rollbacks[k] << " (first such step)\n";
      break;
    }
  for (std::size_t k = 0; k < a.metrics.size() && k < b.metrics.size(); ++k)
    if (a.metrics[k] != b.metrics[k]) {
      os << "  metrics differ from step " << k << " on:";
      for (auto& kv : a.metrics[k]) {
        auto it = b.metrics[k].find(kv.first);
        if (it == b.metrics[k].end() || std::memcmp(&it->second, &kv.second, sizeof(double)) != 0)
          os << " " << kv.first << " (" << kv.second << " vs "
             << (it == b.metrics[k].end() ? std::string("missing") : std::to_string(it->second)) << ")";
      }
      for (auto& kv : b.metrics[k])
        if (!a.metrics[k].count(kv.first)) os << " " << kv.first << " (missing vs " << kv.second << ")";
      os << "\n";
      break;
    }
  for (auto& kv : a.fields) {
    auto it = b.fields.find(kv.first);
    if (it == b.fields.end()) {
      os << "  field " << kv.first << ": missing on one side\n";
      continue;
    }
    const FieldBytes &fa = kv.second, &fb = it->second;
    std::string d;
    if (kv.first == "delaunay.lawson_candidates") {
      // The valid prefix as a set (the order of atomic appends varies); stale entries after it.
      const long na = valid_candidates(a, fa.bytes.size() / 4), nb = valid_candidates(b, fb.bytes.size() / 4);
      if (na != nb) {
        d = "valid lengths " + std::to_string(na) + " vs " + std::to_string(nb);
      } else if (na > 0) {
        std::vector<std::int32_t> ea(std::size_t(na), 0), eb(std::size_t(na), 0);
        std::memcpy(ea.data(), fa.bytes.data(), ea.size() * 4);
        std::memcpy(eb.data(), fb.bytes.data(), eb.size() * 4);
        std::sort(ea.begin(), ea.end());
        std::sort(eb.begin(), eb.end());
        if (ea != eb) d = "the sets of the " + std::to_string(na) + " valid candidates differ";
      }
    } else if (kv.first == "delaunay.status") {
      d = byte_difference(fa, fb, 3, 5);  // words 3-4: Field::version() of position
    } else if (kv.first == "neighbors.moved" || kv.first == "delaunay.lawson_candidate_count") {
      // (published on CUDA only: see the top)
    } else {
      d = byte_difference(fa, fb);
    }
    if (!d.empty()) os << "  field " << kv.first << ": " << d << "\n";
  }
  for (auto& kv : b.fields)
    if (!a.fields.count(kv.first)) os << "  field " << kv.first << ": missing on one side\n";
  return os.str();
}

std::string field_list(const Run& r) {
  std::string s;
  for (auto& kv : r.fields) s += (s.empty() ? "" : ", ") + kv.first;
  return s;
}

}  // namespace

TEST_CASE("CPU and CUDA give the same bits: shipped pipelines, double, 1000 steps", "[cuda][bits]") {
  if (!test::have_cuda("CPU vs CUDA bit identity of the shipped pipelines")) return;
  for (const std::string& name : pipelines()) {
    const Loaded l = load(name, kSteps, Precision::f64);
    const Run c = run(l, Backend::cpu);
    const Run g = run(l, Backend::cuda);
    const std::string diff = differences(c, g);
    INFO(name << ", double, N = " << l.spec.system.N << ", " << kSteps << " steps, CPU vs CUDA:\n" << diff);
    CHECK(diff.empty());
    if (diff.empty())
      WARN("BITS IDENTICAL (double): " << name << ", N = " << l.spec.system.N << ", " << kSteps
                                       << " steps, fields: " << field_list(c) << "; metrics, dt, rollbacks of every step");
  }
}

// A moving trap reads the step's time on the device (ctx.params), advanced there when a captured
// step is replayed: its trajectory must still be the CPU's. trap-hard-disks.yaml (a Verlet-list
// correction) with the trap moving across the box.
TEST_CASE("CPU and CUDA give the same bits: hard disks behind a moving trap, 1000 steps", "[cuda][bits]") {
  if (!test::have_cuda("CPU vs CUDA bit identity of a moving trap")) return;
  const Loaded l = load("trap-hard-disks.yaml", kSteps, Precision::f64, {"step.trap.harmonic.velocity=[3, -2]"});
  const Run c = run(l, Backend::cpu, false);
  const Run g = run(l, Backend::cuda, false);
  const std::string diff = differences(c, g);
  INFO("CPU vs CUDA:\n" << diff);
  CHECK(diff.empty());
  CHECK(c.time == g.time);
}

// On CUDA, overlap_correct leaves reading its results back past the step (the next step's kernels
// queue behind its own: StepContext::may_defer_past_step) unless FLIPFLOW_DEFERRED_READS=0. Run
// without reading the stats in between, so that every step but the last is read back late; the
// same bits and final metrics either way, and against the CPU.
TEST_CASE("CUDA: reads left past the step give the same bits as reads within it", "[cuda][bits]") {
  if (!test::have_cuda("reads left past the step on CUDA")) return;
  for (const std::string& name : {std::string("abp.yaml"), std::string("hard-disks.yaml")}) {
    const Loaded l = load(name, kSteps, Precision::f64);
    const Run late = run(l, Backend::cuda, false);
    ::setenv("FLIPFLOW_DEFERRED_READS", "0", 1);
    const Run within = run(l, Backend::cuda, false);
    ::unsetenv("FLIPFLOW_DEFERRED_READS");
    const Run cpu = run(l, Backend::cpu, false);
    const std::string diff = differences(within, late), diff_cpu = differences(cpu, late);
    INFO(name << ", " << kSteps << " steps, CUDA reading within the step vs past it:\n" << diff);
    CHECK(diff.empty());
    INFO(name << ", CPU vs CUDA reading past the step:\n" << diff_cpu);
    CHECK(diff_cpu.empty());
    CHECK(late.metrics.back().count("overlap_correct/iterations") == 1);
  }
}

// On CUDA, delaunay.detect_inversion leaves its decision to its kernel when nothing is to be
// repaired or rolled back, and delaunay.flip, delaunay.lawson and overlap_correct launch gated on
// it (StepContext::gate) unless FLIPFLOW_DEVICE_DECISIONS=0; steps whose gate closed (inversions,
// rollbacks, many Lawson candidates) run those stages again after the host's decision. The same
// bits and metrics every step either way, and against the CPU (how many steps were decided on
// the device is reported).
namespace {

// `l` on CUDA deciding on the device (the default) and on the host (FLIPFLOW_DEVICE_DECISIONS=0),
// checked against each other and against the CPU; returns the run that decided on the device.
Run decided_both_ways(const Loaded& l, const std::string& what) {
  Run device = run(l, Backend::cuda);
  ::setenv("FLIPFLOW_DEVICE_DECISIONS", "0", 1);
  const Run host = run(l, Backend::cuda);
  ::unsetenv("FLIPFLOW_DEVICE_DECISIONS");
  const Run cpu = run(l, Backend::cpu);
  const std::string diff = differences(host, device), diff_cpu = differences(cpu, device);
  INFO(what << ", CUDA deciding on the host vs on the device:\n" << diff);
  CHECK(diff.empty());
  INFO(what << ", CPU vs CUDA deciding on the device:\n" << diff_cpu);
  CHECK(diff_cpu.empty());
  CHECK(host.decided_on_device == 0);
  CHECK(device.decided_on_device > 0);
  return device;
}

}  // namespace

TEST_CASE("CUDA: steps decided on the device give the same bits as steps decided on the host", "[cuda][bits]") {
  if (!test::have_cuda("device decisions on CUDA")) return;
  for (const std::string& name : {std::string("abp.yaml"), std::string("hard-disks.yaml")}) {
    const Run device = decided_both_ways(load(name, kSteps, Precision::f64), name + ", " + std::to_string(kSteps) + " steps");
    WARN(name << ": " << device.decided_on_device << " of " << kSteps << " steps decided on the device, "
              << device.rollbacks.back() << " rollbacks");
  }
}

// The same where the gate often closes: abp.yaml at Δt = 0.18 (0.44 inverted triangles a step
// on the CPU, ~790 Lawson candidates), so steps decided on the device alternate with steps whose
// gated flip, Lawson and correction did nothing and ran again after the host's decision (every
// repair flip is one of those).
TEST_CASE("CUDA: closed gates give the same bits as steps decided on the host", "[cuda][bits]") {
  if (!test::have_cuda("closed gates on CUDA")) return;
  constexpr std::uint64_t steps = 300;
  const Run device = decided_both_ways(load("abp.yaml", steps, Precision::f64, {"run.dt=0.18"}), "abp.yaml, dt 0.18");
  double flips = 0;
  for (const auto& m : device.metrics) flips += m.at("delaunay.flip/flips");
  CHECK(flips > 0);  // repairs: the gate closed on those steps
  CHECK(device.decided_on_device < steps - flips);
}

// The same with more Lawson flips a step than a pass of its tail kernel (1 024 in one block below
// 32 768 particles): abp.yaml at 16 384 particles and Δt = 0.18, so a device-decided step runs a
// grid round before the tail kernel (lawson/stage.h, run_gated), its kernels' lengths read on the
// device, and closed gates leave those kernels nothing to do.
TEST_CASE("CUDA: Lawson's gated grid round gives the same bits as steps decided on the host", "[cuda][bits]") {
  if (!test::have_cuda("Lawson's gated grid round on CUDA")) return;
  constexpr std::uint64_t steps = 200;
  const Run device = decided_both_ways(load("abp.yaml", steps, Precision::f64, {"system.N=16384", "run.dt=0.18"}),
                                       "abp.yaml, N 16384, dt 0.18");
  double flips = 0, repairs = 0;
  for (const auto& m : device.metrics) {
    const auto it = m.find("delaunay.lawson/lawson_flips");
    if (it != m.end()) flips += it->second;
    repairs += m.at("delaunay.flip/flips");
  }
  WARN("abp.yaml at N 16384, dt 0.18: " << device.decided_on_device << " of " << steps
                                        << " steps decided on the device, " << flips / steps << " Lawson flips a step, "
                                        << repairs << " repair flips");
  CHECK(flips / steps > 1024);  // a pass of the one-block tail: gated launches after such runs run a grid round
  CHECK(repairs > 0);           // closed gates
}

// The same from N = 32 768 on, where delaunay.lawson's tail rounds run on a cluster of 16 blocks
// (lawson/cuda.cu): abp.yaml at 32 768 particles (~570 Lawson candidates a step), its round 0 in
// the cluster's gated launch, or (deciding on the host) in the cluster's launch after the host's
// read. (test_delaunay_lawson has the cluster's rounds of thousands of flips.)
TEST_CASE("CUDA: Lawson's tail on a cluster gives the same bits, decided on the device or on the host", "[cuda][bits]") {
  if (!test::have_cuda("Lawson's cluster tail on CUDA")) return;
  const Run device = decided_both_ways(load("abp.yaml", 100, Precision::f64, {"system.N=32768"}), "abp.yaml, N 32768");
  WARN("abp.yaml at N 32768: " << device.decided_on_device << " of 100 steps decided on the device");
}

// The same at N = 2^18 (~4 600 Lawson candidates a step): device-decided steps whose gated launch
// gives the tail kernel's cluster more candidates than a quarter of its pass (16 384), and whose
// rounds mark up to a pass of edges there.
TEST_CASE("CUDA: Lawson's gated launch with thousands of candidates gives the same bits", "[cuda][bits]") {
  if (!test::have_cuda("Lawson's gated launch at N 2^18 on CUDA")) return;
  constexpr std::uint64_t steps = 20;
  const Run device =
      decided_both_ways(load("abp.yaml", steps, Precision::f64, {"system.N=262144"}), "abp.yaml, N 262144");
  double candidates = 0;
  for (const auto& m : device.metrics) {
    const auto it = m.find("delaunay.detect_inversion/lawson_candidates");
    if (it != m.end()) candidates = std::max(candidates, it->second);
  }
  WARN("abp.yaml at N 262144: " << device.decided_on_device << " of " << steps << " steps decided on the device, at most "
                                 << candidates << " Lawson candidates a step");
  CHECK(candidates > 4096);
}

// Float is not required to match, but nothing in these pipelines should differ either: the same
// IEEE float operations on both sides, sin/cos in double (math.h) rounded to float. Reported,
// not enforced (a difference here is an ulp somewhere, not a broken double run).
TEST_CASE("CPU and CUDA in float (reported, not required)", "[cuda][bits][float][!mayfail]") {
  if (!test::have_cuda("CPU vs CUDA bit identity in float")) return;
  for (const std::string& name : pipelines()) {
    const Loaded l = load(name, kSteps, Precision::f32);
    const Run c = run(l, Backend::cpu);
    const Run g = run(l, Backend::cuda);
    const std::string diff = differences(c, g);
    if (diff.empty())
      WARN("FLOAT BITS IDENTICAL: " << name << ", " << kSteps << " steps");
    else
      WARN("FLOAT DIFFERS: " << name << ":\n" << diff);
    CHECK(diff.empty());
  }
}

TEST_CASE("the comparison itself: two CPU runs of each pipeline agree (the exempt fields by meaning)",
          "[bits]") {
  for (const std::string& name : pipelines()) {
    const Loaded l = load(name, 200, Precision::f64);
    const Run a = run(l, Backend::cpu);
    const Run b = run(l, Backend::cpu);
    const std::string diff = differences(a, b);
    INFO(name << ", two CPU runs:\n" << diff);
    CHECK(diff.empty());
    CHECK(a.fields.count(fields::position) == 1);
  }
}

TEST_CASE("math.h: sincos to an ulp for a general argument; Box–Muller's sincos(2πu) unchanged", "[bits][math]") {
  auto ulps = [](double a, long double exact) {
    const double e = double(exact);
    const double ulp = std::fabs(std::nextafter(e, 2 * e + 1) - e);
    return ulp > 0 ? double(std::fabs(static_cast<long double>(a) - exact) / ulp) : 0.0;
  };
  const RngKey key = make_rng_key(9, "math");
  double worst = 0;
  for (std::uint32_t i = 0; i < (1u << 18); ++i) {
    // Angles of every size ABP sees and more: [−π, π], then up to ±4e5 (reduction by π/2 with
    // one, two or three pieces of π/2).
    const double u = uniform01(key, i, 0, 0, 0), v = uniform01(key, i, 0, 0, 1);
    const double x = i % 2 ? (2 * u - 1) * 3.141592653589793 : (2 * u - 1) * std::ldexp(1.0, int(v * 19));
    double s, c;
    math::sincos(x, s, c);
    worst = std::max({worst, ulps(s, std::sin(static_cast<long double>(x))), ulps(c, std::cos(static_cast<long double>(x)))});
  }
  CHECK(worst < 1.0);
  // Near multiples of π/2, where the reduction cancels the most: still an ulp.
  for (double x : {1.5707963267948966, 3.141592653589793, 4.71238898038469, 6.283185307179586, -3.141592653589793,
                   355.0, 103993.0, 1647099.0}) {
    double s, c;
    math::sincos(x, s, c);
    CHECK(ulps(s, std::sin(static_cast<long double>(x))) < 1.0);
    CHECK(ulps(c, std::cos(static_cast<long double>(x))) < 1.0);
  }
  double s, c;
  math::sincos(0.0, s, c);
  CHECK((s == 0.0 && c == 1.0));
  math::sincos(-0.0, s, c);
  CHECK((s == 0.0 && c == 1.0));
  math::sincos(1e300, s, c);  // beyond the reduction: fmod by 2π first, still in [−1, 1]
  CHECK((std::fabs(s) <= 1 && std::fabs(c) <= 1));
  math::sincos(HUGE_VAL, s, c);
  CHECK((std::isnan(s) && std::isnan(c)));
  // Box–Muller's sincos(2πu) uses the same kernels (moved from rng.h): values as before.
  rng_detail::sincos_2pi(0.25, s, c);
  CHECK((s == 1.0 && c == 0.0));
  rng_detail::sincos_2pi(0.1, s, c);
  CHECK(std::fabs(s - std::sin(0.2L * 3.14159265358979323846264338327950288L)) < 2.3e-16);
}
