// Unwrapped positions x + image·L (host copy), for displacement and MSD checks.
#pragma once
#include <cstdint>
#include <vector>

#include "core/state.h"

namespace ff::test {

template <class R>
std::vector<double> unwrapped(State& s) {
  Field& x = s.field(fields::position);
  Field& im = s.field(fields::image);
  x.acquire(Where::host, Mode::read);
  im.acquire(Where::host, Mode::read);
  std::vector<double> u(x.size());
  for (std::size_t i = 0; i < x.size(); ++i)
    u[i] = double(x.host<R>()[i]) + im.host<std::int32_t>()[i] * s.box.L[i % s.dim()];
  return u;
}

}  // namespace ff::test
