// Rollback: bit-for-bit restore, Δt halving and regrowth, fresh noise per attempt, giving up.
#include <catch2/catch.hpp>
#include <cstring>
#include <vector>

#include "core/base/error.h"
#include "core/backend/host_copy.h"
#include "core/run/rollback.h"
#include "core/run/simulation.h"
#include "support/backends.h"
#include "support/fields.h"
#include "support/spec.h"
#include "support/test_plugins.h"

using namespace ff;
using ff::test::dry;
using ff::test::entry;

namespace {
std::vector<double> positions(Simulation& s) {
  Field& f = s.state().field(fields::position);
  f.acquire(Where::host, Mode::read);
  return std::vector<double>(f.host<double>(), f.host<double>() + f.size());
}
}  // namespace

TEST_CASE("a rolled-back step restores the state bit for bit and retries with fresh noise at Δt/2", "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  // Reference: the same run with no rollback, but taking step 2 at Δt/2 with attempt 1 is not
  // reproducible by a plain run, so compare the restored state itself instead.
  auto s = test::spec(2, 256, 0.2, 4, 0.01,
                      {entry(*r, "brownian.integrate", {{"D", 1.0}}),
                       entry(*r, "testing.rollback", {{"steps", std::vector<double>{2}}, {"fail_attempts", std::int64_t(2)}})});
  s.run.dt_grow_after = 2;
  Simulation sim(s, *r, dry());
  sim.advance();
  sim.advance();
  CHECK(sim.stats().rollbacks == 0);
  const auto before = positions(sim);
  const double t_before = sim.state().time;
  sim.advance();  // step 2: attempts 0 and 1 fail (positions scrambled, restored), attempt 2 passes at Δt/4
  CHECK(sim.stats().rollbacks == 2);
  CHECK(sim.stats().step_rollbacks == 2);
  CHECK(sim.stats().dt == Approx(0.0025));
  CHECK(sim.state().time == Approx(t_before + 0.0025));
  const auto after = positions(sim);
  // No scrambled value survived the restore, and the accepted step moved particles by a
  // Brownian amount of sqrt(2·D·Δt) ≈ 0.07, far from the -1e9 the failed attempts wrote.
  double max_move = 0;
  for (std::size_t i = 0; i < after.size(); ++i) max_move = std::max(max_move, std::fabs(after[i] - before[i]));
  CHECK(max_move < 1.0);
  CHECK(max_move > 0.0);
}

TEST_CASE("snapshot restore is bit-exact", "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto s = test::spec(2, 128, 0.2, 2, 0.01, {entry(*r, "brownian.integrate", {{"D", 1.0}})});
  Simulation sim(s, *r, dry());
  sim.advance();
  Snapshot snap({fields::position, fields::image});
  snap.take(sim.state(), nullptr);
  const auto p0 = positions(sim);
  Field& img = sim.state().field(fields::image);
  std::vector<std::int32_t> i0(img.host<std::int32_t>(), img.host<std::int32_t>() + img.size());
  sim.advance();
  CHECK(positions(sim) != p0);
  snap.restore(sim.state(), nullptr);
  const auto p1 = positions(sim);
  REQUIRE(p1.size() == p0.size());
  CHECK(std::memcmp(p1.data(), p0.data(), p0.size() * sizeof(double)) == 0);
  CHECK(std::memcmp(img.host<std::int32_t>(), i0.data(), i0.size() * sizeof(std::int32_t)) == 0);
}

TEST_CASE("take_before_overwrite swaps storage instead of copying, and restore swaps it back", "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto s = test::spec(2, 128, 0.2, 1, 0.01, {entry(*r, "brownian.integrate", {{"D", 1.0}})});
  Simulation sim(s, *r, dry());
  Field& f = sim.state().field(fields::position);
  const auto p0 = positions(sim);
  const double* storage0 = f.host<double>();
  Snapshot snap({}, {fields::position});
  snap.take(sim.state(), nullptr);
  snap.take_before_overwrite(sim.state(), fields::position);
  CHECK(f.host<double>() != storage0);  // other storage: nothing was copied
  CHECK(f.valid_on(Where::host));
  for (std::size_t i = 0; i < f.size(); ++i) f.host<double>()[i] = -1.0;  // the stage overwrites
  snap.take_before_overwrite(sim.state(), fields::position);  // once per step: no second swap
  CHECK(f.host<double>()[0] == -1.0);
  snap.restore(sim.state(), nullptr);
  CHECK(f.host<double>() == storage0);
  CHECK(positions(sim) == p0);
  Field other("other", f.dtype(), f.components(), f.count() + 1);
  CHECK_THROWS_WITH(f.swap_contents(other), Catch::Contains("differ in shape"));
}

TEST_CASE("a snapshot follows fields whose count a migration changed, growing and shrinking", "[rollback]") {
  // A decomposed team's migration (core/run/domain.h) changes the count of every particle field
  // between two steps; the snapshot's copies are resized without their old contents
  // (Field::resize_discarding) and must still restore the step's start exactly.
  State s(2, Precision::f64, 8);
  Snapshot snap({fields::position}, {fields::image});
  auto fill = [&](double base) {
    Field& p = s.field(fields::position);
    Field& img = s.field(fields::image);
    p.acquire(Where::host, Mode::write);
    img.acquire(Where::host, Mode::write);
    for (std::size_t i = 0; i < p.size(); ++i) p.host<double>()[i] = base + 0.25 * double(i);
    for (std::size_t i = 0; i < img.size(); ++i) img.host<std::int32_t>()[i] = std::int32_t(base) + std::int32_t(i);
  };
  auto bytes = [&](const char* name) { return test::bytes_of(s, name); };
  fill(1);
  snap.take(s, nullptr);
  snap.take_before_overwrite(s, fields::image);
  for (std::size_t n : {std::size_t(13), std::size_t(5), std::size_t(5), std::size_t(21)}) {
    INFO(n << " particles");
    for (auto& name : s.particle_field_names()) s.field(name).resize(n);
    s.set_particles(n, n);
    fill(double(n));
    const auto p0 = bytes(fields::position), i0 = bytes(fields::image);
    snap.take(s, nullptr);
    Field* img_copy = snap.take_before_overwrite(s, fields::image);
    REQUIRE(img_copy);
    CHECK(img_copy->count() == n);
    fill(-100);  // the step writes both
    snap.restore(s, nullptr);
    CHECK(bytes(fields::position) == p0);
    CHECK(bytes(fields::image) == i0);
  }
  Field f("f", DType::f64, 3, 4);
  f.resize_discarding(7);
  CHECK(f.count() == 7);
  CHECK(f.bytes() == 7 * 3 * sizeof(double));
  CHECK(f.valid_on(Where::host));
}

TEST_CASE("host_copy copies every byte, in one piece or in parallel chunks", "[rollback]") {
  // Sizes around the parallel threshold (256 KiB) and the chunk (128 KiB), odd tails included.
  for (std::size_t bytes : {std::size_t(0), std::size_t(1), std::size_t(256 * 1024 - 1), std::size_t(256 * 1024),
                            std::size_t(1024 * 1024 + 3), std::size_t(5 * 128 * 1024 + 77)}) {
    std::vector<unsigned char> src(bytes + 16), dst(bytes + 16, 0xAB);
    for (std::size_t i = 0; i < src.size(); ++i) src[i] = static_cast<unsigned char>(i * 131 + 7);
    host_copy(dst.data() + 8, src.data() + 8, bytes);  // unaligned on purpose
    CHECK(std::memcmp(dst.data() + 8, src.data() + 8, bytes) == 0);
    for (std::size_t i = 0; i < 8; ++i) {  // nothing outside [8, 8 + bytes) is touched
      CHECK(dst[i] == 0xAB);
      CHECK(dst[bytes + 8 + i] == 0xAB);
    }
  }
}

TEST_CASE("Δt grows back after dt_grow_after good steps", "[rollback]") {
  DtController dt(0.01, 0.01 / 64, 3);
  REQUIRE(dt.halve());
  REQUIRE(dt.halve());
  CHECK(dt.dt() == Approx(0.0025));
  dt.accepted(dt.dt());
  dt.accepted(dt.dt());
  CHECK(dt.dt() == Approx(0.0025));
  dt.accepted(dt.dt());
  CHECK(dt.dt() == Approx(0.005));
  for (int k = 0; k < 3; ++k) dt.accepted(dt.dt());
  CHECK(dt.dt() == Approx(0.01));
  for (int k = 0; k < 10; ++k) dt.accepted(dt.dt());
  CHECK(dt.dt() == Approx(0.01));  // never above the configured value
}

TEST_CASE("Δt regrowth inside a run", "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto s = test::spec(2, 64, 0.2, 20, 0.01,
                      {entry(*r, "brownian.integrate"), entry(*r, "testing.rollback", {{"steps", std::vector<double>{1}}})});
  s.run.dt_grow_after = 4;
  Simulation sim(s, *r, dry());
  std::vector<double> dts;
  for (int k = 0; k < 8; ++k) {
    sim.advance();
    dts.push_back(sim.stats().dt);
  }
  // step 0 at dt; step 1 rolled back once -> dt/2; steps 2..5 at dt/2 (4 good); then dt again.
  CHECK(dts[0] == Approx(0.01));
  CHECK(dts[1] == Approx(0.005));
  CHECK(dts[5] == Approx(0.005));
  CHECK(dts[6] == Approx(0.01));
  CHECK(sim.stats().rollbacks == 1);
}

TEST_CASE("past dt_min the run stops, naming step, stage and particles", "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto s = test::spec(2, 64, 0.2, 5, 0.01,
                      {entry(*r, "brownian.integrate"), entry(*r, "testing.rollback", {{"dt_above", 1e-6}}, {"guard"})});
  s.run.dt_min = 0.01 / 8;
  Simulation sim(s, *r, dry());
  CHECK_THROWS_AS(sim.advance(), RunError);
  Simulation sim2(s, *r, dry());
  CHECK_THROWS_WITH(sim2.advance(), Catch::Contains("step 0: stage 'guard' requested a rollback (testing.rollback asked for it)") &&
                                        Catch::Contains("below dt_min = 0.00125") && Catch::Contains("particles involved: 3 1 4"));
  CHECK(sim2.stats().rollbacks == 4);  // dt, dt/2, dt/4, dt/8 all failed
}

TEST_CASE("no snapshot is taken when no stage can request a rollback", "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  auto s = test::spec(2, 64, 0.2, 1, 0.01, {entry(*r, "brownian.integrate")});
  Simulation plain(s, *r, dry());
  CHECK(plain.snapshot_fields().empty());
  s.step.push_back(entry(*r, "testing.rollback"));
  Simulation guarded(s, *r, dry());
  // The integrator rewrites every position and image from the old ones: it hands the snapshot
  // their storage (will_overwrite) instead of a copy being taken before every step; position is
  // copied before every step all the same, because testing.rollback declares a plain write of it.
  CHECK(guarded.snapshot_fields() == std::vector<std::string>{"position"});
  CHECK(guarded.snapshot_on_demand_fields() == std::vector<std::string>{"image"});
}

namespace {
double count_value(Simulation& sim) {
  Field& f = sim.state().field("testing.count");
  f.acquire(Where::host, Mode::read);
  return f.host<double>()[0];
}
}  // namespace

TEST_CASE("on-demand writes are copied when announced and restored on a rollback", "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  // count runs before the stage that fails step 2 once: 1, 2, (3, rolled back to 2), 3.
  const bool announce = GENERATE(true, false);
  // overwrite: announced with will_overwrite (the snapshot swaps storage instead of copying).
  const bool overwrite = announce && GENERATE(false, true);
  auto s = test::spec(2, 64, 0.2, 3, 0.01,
                      {entry(*r, "brownian.integrate"),
                       entry(*r, "testing.count", {{"on_demand", true}, {"announce", announce}, {"overwrite", overwrite}}),
                       entry(*r, "testing.rollback", {{"steps", std::vector<double>{2}}, {"fail_attempts", std::int64_t(1)}})});
  Simulation sim(s, *r, dry());
  CHECK(sim.snapshot_fields() == std::vector<std::string>{"position"});  // testing.rollback's plain write
  CHECK(sim.snapshot_on_demand_fields() == std::vector<std::string>{"image", "testing.count"});
  sim.run();
  CHECK(sim.stats().rollbacks == 1);
  // A stage that breaks the contract (writes without announcing) is not restored: what the
  // announcement is for.
  CHECK(count_value(sim) == (announce ? 3.0 : 4.0));
}

TEST_CASE("on the CPU, writes after every stage that may roll back are not copied", "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  // A rollback request stops the step before count runs, so count's field never needs a copy
  // and the rolled-back attempt never reaches it: 1, 2, 3.
  auto s = test::spec(2, 64, 0.2, 3, 0.01,
                      {entry(*r, "brownian.integrate"),
                       entry(*r, "testing.rollback", {{"steps", std::vector<double>{2}}, {"fail_attempts", std::int64_t(2)}}),
                       entry(*r, "testing.count")});
  Simulation sim(s, *r, dry());
  CHECK(sim.snapshot_fields() == std::vector<std::string>{"position"});  // testing.rollback's plain write
  CHECK(sim.snapshot_on_demand_fields() == std::vector<std::string>{"image"});
  sim.run();
  CHECK(sim.stats().rollbacks == 2);
  CHECK(count_value(sim) == 3.0);
}

TEST_CASE("a stage after every requester gets no snapshot when the requests come from run() only",
          "[rollback]") {
  auto r = test::registry_with({"brownian"}, {"testing"});
  const Backend backend = GENERATE(from_range(test::backends()));
  const bool device_requests = GENERATE(true, false);
  // The field is on demand because `before` may write it before the rollback request; `after`
  // (as delaunay.lawson after detect_inversion) announces its writes too. A request returned by
  // run() stops the step before `after` runs, so nothing can roll `after` back: it is handed no
  // snapshot (its announcement copies nothing), on the CPU always, on CUDA unless the requester
  // may also request from its kernels (read at the end of the step, after `after` ran).
  auto s = test::spec(2, 64, 0.2, 3, 0.01,
                      {entry(*r, "brownian.integrate"),
                       entry(*r, "testing.count", {{"on_demand", true}}, {"before"}),
                       entry(*r, "testing.rollback",
                             {{"steps", std::vector<double>{2}},
                              {"fail_attempts", std::int64_t(1)},
                              {"device_requests", device_requests}}),
                       entry(*r, "testing.count", {{"on_demand", true}}, {"after"})});
  Simulation sim(s, *r, dry(backend));
  CHECK(sim.snapshot_on_demand_fields() == std::vector<std::string>{"image", "testing.count"});  // + the integrator's
  sim.run();
  CHECK(sim.stats().rollbacks == 1);
  CHECK(sim.stats().metrics.at("before/snapshot") == 1.0);
  const bool after_undone = backend == Backend::cuda && device_requests;
  CHECK(sim.stats().metrics.at("after/snapshot") == (after_undone ? 1.0 : 0.0));
  // 3 accepted steps, two increments each; the rolled-back attempt's first increment undone.
  CHECK(count_value(sim) == 6.0);
}
