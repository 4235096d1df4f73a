// What the non-finite check's tests share (this folder's test_non_finite.cpp and
// plugins/abp/integrate/test_non_finite.cpp): put a value into a particle's field, and run until
// the check stops the run.
#pragma once
#include <cstdint>
#include <string>

#include "core/base/error.h"
#include "core/run/simulation.h"

namespace ff::test {

// Sets component k of particle i of `field` to `value` (on the host; the next step copies it over).
inline void put(Simulation& sim, const char* field, std::size_t i, int k, double value) {
  Field& f = sim.state().field(field);
  f.acquire(Where::host, Mode::readwrite);
  const std::size_t at = i * std::size_t(f.components()) + std::size_t(k);
  if (f.dtype() == DType::f64) f.host<double>()[at] = value;
  else f.host<float>()[at] = float(value);
}

// Advances `steps` steps and finishes the run: "" then, else the message of the RunError that
// stopped it.
inline std::string advance_until_error(Simulation& sim, std::uint64_t steps) {
  try {
    for (std::uint64_t k = 0; k < steps; ++k) sim.advance();
    sim.finish(true);
  } catch (const RunError& e) {
    return e.what();
  }
  return "";
}

}  // namespace ff::test
