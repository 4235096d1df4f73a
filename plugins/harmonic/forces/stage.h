// harmonic.forces: the contact force of kernel.h on every particle, summed over its row of the
// Verlet list of a neighbors.verlet stage before it, into the `force` field that
// overdamped.integrate reads; 2D and 3D, CPU and CUDA (stages/neighbors/pair_force.h).
#pragma once
#include "plugins/harmonic/forces/kernel.h"

namespace ff::harmonic {

struct Harmonic {
  static constexpr const char* name = "harmonic.forces";
  static constexpr const char* summary = "soft disks/spheres: F_ij = k (σ_ij − r) r̂_ij for r < σ_ij = (σ_i + σ_j)/2";
  double k = 100;

  template <class P>
  void describe(P& p) {
    p(k, "k", "stiffness k (k_BT/length², box units) of the contact force k (σ_ij − r) r̂ between overlapping particles").above(0);
  }
  // Particles feel each other only while they overlap.
  double range(double sigma_i, double sigma_j) const { return 0.5 * (sigma_i + sigma_j); }
  template <class R, int D>
  HarmonicForce<R, D> kernel() const { return {R(k)}; }
};

template <class R>
using Forces = neighbors::PairForceStage<R, Harmonic>;

}  // namespace ff::harmonic

FLIPFLOW_STAGE(ff::harmonic::Forces)
