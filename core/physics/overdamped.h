// The overdamped (Euler–Maruyama) position update every integrator shares, written once:
//   x_k += drift_k + amplitude · ξ_k,  then wrapped into the periodic box with the crossing
// counted in `image`. drift is the deterministic displacement of the step (v Δt, or none),
// amplitude = sqrt(2 D Δt), ξ truncated unit Gaussians (core/physics/rng.h). nvcc-clean.
//
// An integrator's functor F splits its step into the noise and the move, so the CPU loop can
// draw the noise of several particles at once (core/backend/overdamped_cpu.h) while the GPU draws it
// per thread (overdamped_step); both call the same F::move:
//   static constexpr int kNoisePairs;              Gaussian pairs per particle
//   FF_HD std::uint32_t noise_pair(int j) const;   the pair index (core/physics/rng.h) of the j-th pair
//   FF_HD NoiseCounter noise_counter() const;      key, step, attempt, Gaussian tail
//   FF_HD void move(std::size_t i, const double* z) const;  z[2j], z[2j + 1]: pair j
// and optionally, for the CPU loop only (the GPU's element operation is F::operator()(i)):
//   void after_moves(std::size_t first, std::size_t count) const;  once per block of particles
//                                                   after their moves (a check of what they wrote)
// The standard integrator's functor (OverdampedStep, stages/overdamped/integrate/kernel.h) is
// this step for every model whose particles diffuse and drift; a model adds its deterministic
// displacement, and any degree of freedom that moves with it, as a drift functor (abp.integrate's
// self-propulsion and orientation), the extension point below.
#pragma once
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "core/physics/box.h"
#include "core/base/hd.h"
#include "core/physics/rng.h"

namespace ff {

struct NoiseCounter {
  RngKey key;
  std::uint64_t step;
  std::uint32_t attempt;
  GaussianTail tail = GaussianTail::rescaled;  // how the Gaussians are kept within ±3 (rng.h)
  // The particle numbers the noise is keyed by: particle i draws as particle id[i]. Null: as i.
  // A decomposed team's rank holds some particles in its own order (core/run/domain.h); keyed by
  // their global ids they draw the numbers they draw alone.
  const std::uint32_t* id = nullptr;
};

// Reads particle i from (position_in, image_in) and writes it to (position, image): the same
// arrays for an update in place, or the previous step's kept by the rollback snapshot
// (StepContext::will_overwrite) for one that spares the snapshot its copy.
template <class R, int D>
FF_HD void overdamped_move(const R* position_in, const std::int32_t* image_in, R* position, std::int32_t* image,
                           const PeriodicBox<R>& box, std::size_t i, const R* drift, R amplitude, const double* xi) {
  for (int k = 0; k < D; ++k) {
    R x = position_in[i * D + k];
    std::int32_t n = image_in[i * D + k];
    if (drift) x += drift[k];
    x += amplitude * R(xi[k]);
    box.wrap(x, n, k);
    position[i * D + k] = x;
    image[i * D + k] = n;
  }
}

template <class R, int D>
FF_HD void overdamped_move(R* position, std::int32_t* image, const PeriodicBox<R>& box, std::size_t i,
                           const R* drift, R amplitude, const double* xi) {
  overdamped_move<R, D>(position, image, position, image, box, i, drift, amplitude, xi);
}

// The drift extension point of the standard step: a functor G with
//   static constexpr int kNoisePairs;              Gaussian pairs of its own, drawn after the
//                                                  translation's (pairs 0, and 1 in 3D)
//   FF_HD std::uint32_t noise_pair(int j) const;   the pair index of its j-th pair
//   template <class R> FF_HD bool operator()(std::size_t i, int type, double dt, const double* z,
//                                            R* drift) const;
// which writes particle i's (of type `type`) deterministic displacement over Δt = dt into
// drift[0 .. D-1] and returns true, or returns false when it has none (the step then adds
// nothing: not even a zero, which would turn -0 into +0). z holds its own pairs (z[2j],
// z[2j + 1]: pair j). It may also update fields of its own from their values at the start of the
// step (abp.integrate turns the orientation it propels along).
struct NoDrift {
  static constexpr int kNoisePairs = 0;
  FF_HD std::uint32_t noise_pair(int) const { return 0; }
  template <class R>
  FF_HD bool operator()(std::size_t, int, double, const double*, R*) const { return false; }
};

// Whether F has after_moves (above).
template <class F, class = void>
struct HasAfterMoves : std::false_type {};
template <class F>
struct HasAfterMoves<F, std::void_t<decltype(std::declval<const F&>().after_moves(std::size_t{}, std::size_t{}))>>
    : std::true_type {};

// One particle's step: its Gaussian pairs, then F::move (the element operation of the GPU loop).
template <class F>
FF_HD void overdamped_step(const F& f, std::size_t i) {
  const NoiseCounter c = f.noise_counter();
  double z[2 * F::kNoisePairs];
  for (int j = 0; j < F::kNoisePairs; ++j)
    gaussian_pair(c.key, c.id ? c.id[i] : std::uint32_t(i), c.step, c.attempt, f.noise_pair(j), z[2 * j], z[2 * j + 1], c.tail);
  f.move(i, z);
}

}  // namespace ff
