// The boids' fields and their initial headings, shared by the boids stages.
//
//   boids.heading   real x2: u_i, the unit vector each boid flies along (speed v0)
//   boids.steering  real x2: F_i = A s_i + [n_i > 0] (C ā_i + B (c̄_i − x_i)), written by
//                   boids.forces from the state at the start of the step, read by boids.integrate
//
// The heading is stored as a unit vector, not an angle: the rules, the polarisation and the
// authors' map all work on u, and renders read an (N, 2) field as the angle atan2(u_y, u_x).
// nvcc-clean.
#pragma once
#include <cstdint>
#include <string>

#include "core/base/error.h"
#include "core/physics/math.h"
#include "core/physics/rng.h"
#include "core/stage/state.h"

namespace ff::boids {

inline constexpr const char* kHeading = "boids.heading";
inline constexpr const char* kSteering = "boids.steering";
constexpr double kPi = 3.14159265358979323846;

// Gives the state its heading field when no stage has yet, filled with uniformly random
// directions keyed by (seed, "boids.heading") — the same on every backend, independent of the
// stage that adds it; checks the shape of one that exists. `who` names the stage in errors.
template <class R>
void ensure_heading(State& s, std::uint64_t seed, const std::string& who) {
  if (s.has_field(kHeading)) {
    const Field& f = s.field(kHeading);
    if (f.dtype() != s.real() || f.components() != 2 || f.count() != s.n())
      throw InputError(who + ": the field 'boids.heading' exists with " + to_string(f.dtype()) + " x" +
                       std::to_string(f.components()) + "; it must hold " + to_string(s.real()) +
                       " x2 (a unit vector per boid)");
    return;
  }
  Field& f = s.add_particle_field(kHeading, s.real(), 2);
  f.acquire(Where::host, Mode::write);
  const RngKey key = make_rng_key(seed, "boids.heading");
  R* u = f.host<R>();
  for (std::size_t i = 0; i < s.n(); ++i) {
    double sn, cs;
    math::sincos(2 * kPi * uniform01(key, std::uint32_t(i), 0, 0, 0), sn, cs);
    u[2 * i] = R(cs);
    u[2 * i + 1] = R(sn);
  }
}

}  // namespace ff::boids
