// Active Brownian Particles, one Euler–Maruyama step per particle (Carter et al. 2017, eq. 10-11):
//
//   x  += v0 e(θ) Δt + sqrt(2 D Δt) ξ          e(θ) = (cos θ, sin θ) in 2D
//   θ  += sqrt(2 D_r Δt) η                     (2D: the orientation field holds θ)
//
// In 3D the orientation field holds a unit vector e; it is rotated about the random axis
// ω = sqrt(2 D_r Δt) η (η a 3-vector of unit Gaussians) by the angle |ω| (Rodrigues), which
// keeps |e| = 1 and gives <e(t)·e(0)> = exp(-2 D_r t) to first order in Δt, then renormalised
// so rounding never accumulates. Self-propulsion uses the orientation at the start of the step.
// The noise is the truncated, variance-corrected Gaussian of core/physics/rng.h; each quantity has its
// own pair indices (translation: pairs 0-1, rotation: pairs 2-3), so none share numbers.
// sin and cos are core/physics/math.h's (in double for either precision, then rounded to R): the CPU and
// CUDA loops give the same bits (with the CUDA loop built without fma contraction, -fmad=false).
// The translation is overdamped.integrate's step (stages/overdamped/integrate/kernel.h), fed the
// self-propulsion as its drift; this file holds only that drift and the orientation's step.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/math.h"
#include "core/physics/overdamped.h"
#include "core/physics/rng.h"
#include "stages/overdamped/integrate/kernel.h"

namespace ff::abp {

constexpr std::uint32_t kRotationPair = 2;  // pairs 2 (and 3 in 3D); translation: 0 (and 1)
constexpr double kPi = 3.14159265358979323846;

// θ brought into [-π, π) (keeps float angles precise over long runs).
template <class R>
FF_HD R wrap_angle(R theta) {
  const R two_pi = R(2 * kPi);
  return theta - two_pi * std::floor((theta + R(kPi)) / two_pi);
}

// abp.integrate's drift functor (core/physics/overdamped.h): the self-propulsion v0 e Δt along
// the orientation at the start of the step, and the orientation's own step. The rest of the step
// (translation noise, wrap, image) is the standard one: AbpStep below.
template <class R, int D>
struct SelfPropulsion {
  // Read from orientation_in, written to orientation: the same array (in place) or the previous
  // step's, kept by the rollback snapshot (stage.h).
  const R* orientation_in;
  R* orientation;  // N x 1 (θ) in 2D, N x 3 (unit vector) in 3D
  double v0;       // self-propulsion speed
  double two_Dr;   // 2 D_r

  // The rotation's pairs: 2 in 2D, 2-3 in 3D (after the translation's 0, and 1 in 3D).
  static constexpr int kNoisePairs = D == 2 ? 1 : 2;
  FF_HD std::uint32_t noise_pair(int j) const { return kRotationPair + std::uint32_t(j); }

  // eta: the rotation's Gaussians η.
  FF_HD bool operator()(std::size_t i, int, double dt, const double* eta, R* drift) const {
    const R rot_amp = R(std::sqrt(two_Dr * dt));  // sqrt(2 D_r Δt)
    R e[3];
    if constexpr (D == 2) {
      const R th = orientation_in[i];
      double s, c;
      math::sincos(double(th), s, c);  // core/physics/math.h: the same bits on both backends
      e[0] = R(c);
      e[1] = R(s);
      orientation[i] = wrap_angle(th + rot_amp * R(eta[0]));
    } else {
      for (int k = 0; k < 3; ++k) e[k] = orientation_in[i * 3 + k];
      rotate_3d(e, rot_amp, eta, &orientation[i * 3]);
    }
    const R v0_dt = R(v0 * dt);
    for (int k = 0; k < D; ++k) drift[k] = v0_dt * e[k];  // self-propulsion along e
    return true;
  }

  // Whether the orientations of particles [first, first + count) are finite after their step
  // (the step's non-finite check, stages/overdamped/integrate/kernel.h).
  FF_HD bool finite(std::size_t first, std::size_t count) const {
    constexpr std::size_t c = D == 2 ? 1 : 3;
    return overdamped::all_finite(orientation + first * c, count * c);
  }

  // out = e rotated about ω = rot_amp·η by |ω|, renormalised.
  FF_HD static void rotate_3d(const R e[3], R rot_amp, const double eta[3], R* out) {
    R w[3] = {rot_amp * R(eta[0]), rot_amp * R(eta[1]), rot_amp * R(eta[2])};
    const R angle = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    R r[3] = {e[0], e[1], e[2]};
    if (angle > R(0)) {
      for (int k = 0; k < 3; ++k) w[k] /= angle;
      double sd, cd;
      math::sincos(double(angle), sd, cd);
      const R c = R(cd), s = R(sd);
      const R dot = w[0] * e[0] + w[1] * e[1] + w[2] * e[2];
      const R cross[3] = {w[1] * e[2] - w[2] * e[1], w[2] * e[0] - w[0] * e[2], w[0] * e[1] - w[1] * e[0]};
      for (int k = 0; k < 3; ++k) r[k] = e[k] * c + cross[k] * s + w[k] * dot * (R(1) - c);
    }
    const R inv = R(1) / std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    for (int k = 0; k < 3; ++k) out[k] = r[k] * inv;
  }
};

// The whole step: the standard overdamped one (one D for every particle, no max_step check)
// driven by the self-propulsion, reading the previous step where will_overwrite says (stage.h).
template <class R, int D>
using AbpStep = overdamped::OverdampedStep<R, D, false, SelfPropulsion<R, D>, false>;

// Uniformly random initial orientations: θ uniform in [-π, π) in 2D, e uniform on the unit
// sphere in 3D (z uniform in [-1, 1], azimuth uniform). Keyed by (seed, "abp.orientation").
template <class R, int D>
struct RandomOrientation {
  R* orientation;
  RngKey key;

  FF_HD void operator()(std::size_t i) const {
    const auto p = std::uint32_t(i);
    const double u0 = uniform01(key, p, 0, 0, 0);
    if constexpr (D == 2) {
      orientation[i] = wrap_angle(R(2 * kPi * u0 - kPi));
    } else {
      const double z = 2 * u0 - 1;
      const double phi = 2 * kPi * uniform01(key, p, 0, 0, 1);
      const double rho = std::sqrt(std::fmax(0.0, 1 - z * z));
      double s, c;
      math::sincos(phi, s, c);
      orientation[i * 3 + 0] = R(rho * c);
      orientation[i * 3 + 1] = R(rho * s);
      orientation[i * 3 + 2] = R(z);
    }
  }
};

}  // namespace ff::abp
