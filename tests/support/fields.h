// Field contents on the host for checks: unwrapped positions x + image·L (displacements, MSD),
// any real field (the positions among them) as doubles, and any field's bytes (bit-for-bit comparisons).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/stage/state.h"

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

// A real field's contents, as doubles, fetched to the host.
inline std::vector<double> values(State& s, const char* name) {
  Field& f = s.field(name);
  f.acquire(Where::host, Mode::read);
  std::vector<double> v(f.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    v[i] = s.precision() == Precision::f64 ? f.host<double>()[i] : double(f.host<float>()[i]);
  return v;
}

// The positions (wrapped into the box), as doubles, fetched to the host.
inline std::vector<double> positions(State& s) { return values(s, fields::position); }

// A field's bytes, fetched to the host.
inline std::vector<unsigned char> bytes_of(State& s, const std::string& name) {
  Field& f = s.field(name);
  f.acquire(Where::host, Mode::read);
  const auto* p = static_cast<const unsigned char*>(f.host_raw());
  return {p, p + f.bytes()};
}

}  // namespace ff::test
