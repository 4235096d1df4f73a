// observe.msd alone: the same bits for any thread count (its value against the H5MD file, with a
// hand-computed case, is in stages/observe/h5md/test_h5md.cpp).
#include <oneapi/tbb/global_control.h>

#include <catch2/catch.hpp>
#include <cstdint>

#include "core/stage/state.h"
#include "stages/observe/msd/stage.h"
#include "support/stage_driver.h"

using namespace ff;

TEST_CASE("observe.msd gives the same bits for any thread count", "[observe][msd]") {
  const std::size_t n = 200000;
  State s(3, Precision::f64, n);
  s.box.L[0] = s.box.L[1] = s.box.L[2] = 50.0;
  std::uint64_t r = 12345;
  auto next = [&] {
    r = r * 6364136223846793005ull + 1442695040888963407ull;
    return double(r >> 11) / double(1ull << 53);
  };
  double* x = s.field(fields::position).host<double>();
  std::int32_t* im = s.field(fields::image).host<std::int32_t>();
  for (std::size_t i = 0; i < 3 * n; ++i) x[i] = 50.0 * next();
  auto value = [&](int threads) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    observe::Msd msd;
    test::StageDriver driver(Backend::cpu, Precision::f64, 3);
    for (std::size_t i = 0; i < 3 * n; ++i) im[i] = 0;
    driver.run(msd, s, 0);
    for (std::size_t i = 0; i < 3 * n; ++i) im[i] = std::int32_t(i % 5) - 2;
    driver.run(msd, s, 1);
    return driver.metric("msd");
  };
  const double one = value(1);
  // Every image is i % 5 - 2 along each axis: MSD = L² Σ_k (i_k)² averaged = 2500 · 3 · 2 = 15000.
  CHECK(one == Approx(15000.0).epsilon(1e-3));
  CHECK(value(4) == one);
  CHECK(value(2) == one);
}
