#include "stages/observe/msd/stage.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_reduce.h>

#include "stages/observe/msd/kernel.h"

namespace ff::observe {

namespace {

template <class R, int D>
Unwrap<R, D> unwrap_of(const State& s) {
  return {s.field(fields::position).host<R>(), s.field(fields::image).host<std::int32_t>(),
          {s.box.L[0], s.box.L[1], s.box.L[2]}};
}

template <class F>
decltype(auto) dispatch(const State& s, F&& f) {
  const bool f32 = s.precision() == Precision::f32;
  if (s.dim() == 2) return f32 ? f(unwrap_of<float, 2>(s)) : f(unwrap_of<double, 2>(s));
  return f32 ? f(unwrap_of<float, 3>(s)) : f(unwrap_of<double, 3>(s));
}

constexpr std::size_t grain = 4096;

}  // namespace

void unwrapped_positions(const State& s, std::vector<double>& out) {
  const int d = s.dim();
  out.resize(s.n() * std::size_t(d));
  dispatch(s, [&](const auto& u) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, s.n(), grain), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i)
        for (int k = 0; k < d; ++k) out[i * d + k] = u(i, k);
    });
  });
}

double sum_squared_displacement(const State& s, const std::vector<double>& reference) {
  // parallel_deterministic_reduce splits by the grain alone (never by thread count or timing),
  // so the additions happen in the same order on every run.
  return dispatch(s, [&](const auto& u) {
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::size_t>(0, s.n(), grain), 0.0,
        [&](const tbb::blocked_range<std::size_t>& r, double acc) {
          for (std::size_t i = r.begin(); i != r.end(); ++i) acc += squared_displacement(u, reference.data(), i);
          return acc;
        },
        [](double a, double b) { return a + b; });
  });
}

}  // namespace ff::observe
