// observe.mean against hand-computed means: all particles and one type, one and two components,
// float and double; NaN (and count) for a field nothing has written yet; the errors name the key.
#include <catch2/catch.hpp>
#include <cmath>

#include "core/stage/state.h"
#include "stages/observe/mean/stage.h"
#include "support/stage_driver.h"

using namespace ff;

namespace {

observe::Mean make_mean(const std::string& field, std::vector<std::string> types = {}) {
  ParamValues v = ParamValues::defaults(schema_of<observe::MeanParams>());
  v.set("field", field);
  v.set("types", types);
  RunInfo info;
  info.stage_id = "probe";
  return observe::Mean(v, info);
}

// Four particles of types a, b, a, b; "u" (1 component) = 1, 2, 4, 8 and "w" (2) = (i, −2i).
std::unique_ptr<State> make_state(Precision p) {
  auto s = std::make_unique<State>(2, p, 4);
  s->species = {"a", "b"};
  Field& t = s->field(fields::type);
  t.acquire(Where::host, Mode::write);
  for (int i = 0; i < 4; ++i) t.host<std::int32_t>()[i] = i % 2;
  s->add_particle_field("u", s->real(), 1);
  s->add_particle_field("w", s->real(), 2);
  s->add_particle_field("never", s->real(), 1);
  s->add_particle_field("n", DType::i32, 1);
  Field& u = s->field("u");
  Field& w = s->field("w");
  u.acquire(Where::host, Mode::write);
  w.acquire(Where::host, Mode::write);
  const double uv[4] = {1, 2, 4, 8};
  for (int i = 0; i < 4; ++i) {
    if (p == Precision::f64) {
      u.host<double>()[i] = uv[i];
      w.host<double>()[2 * i] = i;
      w.host<double>()[2 * i + 1] = -2.0 * i;
    } else {
      u.host<float>()[i] = float(uv[i]);
      w.host<float>()[2 * i] = float(i);
      w.host<float>()[2 * i + 1] = float(-2.0 * i);
    }
  }
  return s;
}

}  // namespace

TEST_CASE("observe.mean: per component, over all particles or the named types", "[observe][mean]") {
  const Precision p = GENERATE(Precision::f64, Precision::f32);
  auto s = make_state(p);
  test::StageDriver d(Backend::cpu, p, 2);

  auto all = make_mean("u");
  all.configure(*s);
  d.run(all, *s);
  CHECK(d.metric("mean") == 15.0 / 4);
  CHECK(d.metric("count") == 4);

  auto of_b = make_mean("u", {"b"});
  of_b.configure(*s);
  d.run(of_b, *s);
  CHECK(d.metric("mean") == 5.0);
  CHECK(d.metric("count") == 2);

  auto w = make_mean("w", {"a"});
  w.configure(*s);
  d.run(w, *s);
  CHECK(d.metric("mean_x") == 1.0);   // particles 0 and 2
  CHECK(d.metric("mean_y") == -2.0);
  CHECK(d.metric("count") == 2);

  auto both = make_mean("w", {"a", "b"});
  both.configure(*s);
  d.run(both, *s);
  CHECK(d.metric("mean_x") == 1.5);
  CHECK(d.metric("mean_y") == -3.0);

  // Nothing wrote it (the initial frame of a field the steps compute): NaN, as observe.h5md writes it.
  auto never = make_mean("never");
  never.configure(*s);
  d.run(never, *s);
  CHECK(std::isnan(d.metric("mean")));
  CHECK(d.metric("count") == 4);
}

TEST_CASE("observe.mean: its errors name the key and what exists", "[observe][mean]") {
  auto s = make_state(Precision::f64);
  auto missing = make_mean("uu");
  CHECK_THROWS_WITH(missing.configure(*s), Catch::Contains("step 'probe' (observe.mean): field: there is no per-particle "
                                                           "field 'uu'") &&
                                               Catch::Contains("did you mean 'u'") && Catch::Contains("never, position"));
  auto ints = make_mean("n");
  CHECK_THROWS_WITH(ints.configure(*s), Catch::Contains("'n' holds integers"));
  auto type = make_mean("u", {"c"});
  CHECK_THROWS_WITH(type.configure(*s), Catch::Contains("types names `c`, which is not one of system.types (a, b)"));
}
