// Initial conditions: the box, the species of every particle and non-overlapping positions,
// built from a validated SystemSpec. Every random choice draws from Philox with the key
// make_rng_key(seed, "init"), so the result depends on the seed only — never on threads.
//
// `system.init` options:
//   random                     random sequential addition (RSA): particles are dropped at
//                              uniform random positions, largest first, and a drop that would
//                              overlap a placed particle is redrawn. Looks like a fluid, but
//                              jams near φ ≈ 0.547 (2D) / 0.38 (3D); denser systems need a lattice.
//                              Slows down near jamming (10⁶ disks: ~3 s at φ = 0.3, ~1 min at 0.5).
//   triangular_lattice_sample  (2D, Carter et al. 2017) a triangular lattice with at least N
//                              sites fitting the periodic box, nearest-neighbour distance ≥ the
//                              largest diameter; N sites are chosen by reservoir sampling.
//                              Reaches φ up to π/(2√3) ≈ 0.907 for equal disks.
//   lattice_sample             2D: the same as triangular_lattice_sample. 3D: the simple cubic
//                              or fcc lattice (whichever spaces the sites wider) sampled the
//                              same way; fcc reaches φ up to π/(3√2) ≈ 0.740.
// Species are assigned by fraction: exactly round(f·N) particles each (fixed up to sum to N),
// in a seeded Fisher–Yates order, independent of the positions.
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/input/pipeline_spec.h"
#include "core/stage/state.h"

namespace ff {

// The periodic box: `system.box` when given, else a square (cubic) box whose edge makes the
// packing fraction come out exactly: Σ π d_i²/4 / L² (2D) or Σ π d_i³/6 / L³ (3D), with
// d_i = sigma × species diameter over the exact species counts. Throws InputError on bad input.
Box make_box(const SystemSpec& system);

// Exact number of particles of each species: round(f_k·N) with normalised fractions, then
// adjusted one at a time (the species rounded furthest the wrong way first) to sum to N.
std::vector<std::uint64_t> species_counts(const SystemSpec& system);

// A fresh state: box, species names and diameters, and the `type`, `diameter`, `position` and
// (zero) `image` fields, placed by `system.init`. Throws InputError when the input is wrong or
// too dense for the chosen placement (the message says what to change). wall_axis: the axis of the
// pipeline's hard walls (overlap_correct's `walls`, at 0 and L along it; -1: none): `random` then
// draws every centre at least d_i/2 from both walls (the lattices and `from` take no account of them).
std::unique_ptr<State> make_initial_state(const SystemSpec& system, Precision precision,
                                          std::uint64_t seed, int wall_axis = -1);

// The lattice that lattice placement samples from: at least `n_min` sites in `box` (2D:
// triangular; 3D: simple cubic or fcc), chosen to make the smallest periodic (minimum-image)
// distance between sites as large as possible. `spacing` gets that distance. Exposed for tests.
std::vector<std::array<double, 3>> lattice_sites(const Box& box, std::uint64_t n_min,
                                                 double& spacing);

}  // namespace ff
