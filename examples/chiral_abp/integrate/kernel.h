// Chiral active Brownian particles in 2D, "circle swimmers" (van Teeffelen & Löwen, PRE 78,
// 020101 (2008)): one Euler–Maruyama step per particle,
//
//   θ += ω Δt + sqrt(2 D_r Δt) η                e(θ) = (cos θ, sin θ)
//   x += v0 e(θ) Δt + sqrt(2 D Δt) ξ
//
// With D_r = 0 a particle runs around a circle of radius v0/|ω| (counter-clockwise for ω > 0).
// Self-propulsion uses the orientation at the start of the step. Everything here is flipflow's:
// the Gaussians (core/physics/rng.h, drawn 16 particles at a time on the CPU by the overdamped loop),
// the position update with its periodic wrap (core/physics/overdamped.h, core/physics/box.h) and sin/cos
// (core/physics/math.h: the same bits on the CPU and the GPU). The noise pairs are abp.integrate's:
// translation pair 0 (ξ = z[0], z[1]), rotation pair 2 (η = z[2]). nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/physics/box.h"
#include "core/base/hd.h"
#include "core/physics/math.h"
#include "core/physics/overdamped.h"
#include "core/physics/rng.h"
#include "core/stage/step_params.h"

namespace chiral_abp {

constexpr std::uint32_t kTranslationPair = 0;
constexpr std::uint32_t kRotationPair = 2;
constexpr double kPi = 3.14159265358979323846;

// θ brought into [-π, π) (keeps float angles precise over long runs).
template <class R>
FF_HD R wrap_angle(R theta) {
  const R two_pi = R(2 * kPi);
  return theta - two_pi * std::floor((theta + R(kPi)) / two_pi);
}

template <class R>
struct ChiralStep {
  // Particle i is read from the *_in arrays and written to the others (the same arrays, or the
  // previous step's kept by the rollback snapshot: see stage.h).
  const R* position_in;
  const std::int32_t* image_in;
  const R* orientation_in;
  R* position;          // N x 2
  std::int32_t* image;  // N x 2
  R* orientation;       // N x 1: θ
  ff::PeriodicBox<R> box;
  double v0;      // self-propulsion speed
  double omega;   // angular velocity
  double two_D;   // 2 D
  double two_Dr;  // 2 D_r
  ff::RngKey key;
  // Δt, the step and the attempt, on the loop's side (ff::StepContext::params): read here, never
  // passed by value, so a CUDA run can replay the step from a captured graph.
  const ff::StepParams* params;

  // What the overdamped loop needs (core/physics/overdamped.h): two Gaussian pairs per particle.
  static constexpr int kNoisePairs = 2;
  FF_HD std::uint32_t noise_pair(int j) const { return j == 0 ? kTranslationPair : kRotationPair; }
  FF_HD ff::NoiseCounter noise_counter() const { return {key, params->step, params->attempt}; }

  // z[0], z[1]: ξ; z[2]: η.
  FF_HD void move(std::size_t i, const double* z) const {
    const double dt = params->dt;
    const R v0_dt = R(v0 * dt), omega_dt = R(omega * dt);
    const R trans_amp = R(std::sqrt(two_D * dt)), rot_amp = R(std::sqrt(two_Dr * dt));
    const R th = orientation_in[i];
    double s, c;
    ff::math::sincos(double(th), s, c);
    const R drift[2] = {v0_dt * R(c), v0_dt * R(s)};
    orientation[i] = wrap_angle(th + omega_dt + rot_amp * R(z[2]));
    ff::overdamped_move<R, 2>(position_in, image_in, position, image, box, i, drift, trans_amp, z);
  }

  FF_HD void operator()(std::size_t i) const { ff::overdamped_step(*this, i); }
};

// Uniformly random initial angles in [-π, π), keyed by (seed, "chiral_abp.orientation").
template <class R>
struct RandomAngle {
  R* orientation;
  ff::RngKey key;
  FF_HD void operator()(std::size_t i) const {
    orientation[i] = wrap_angle(R(2 * kPi * ff::uniform01(key, std::uint32_t(i), 0, 0, 0) - kPi));
  }
};

}  // namespace chiral_abp
