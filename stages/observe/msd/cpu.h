#pragma once
#include <vector>

#include "core/state.h"

namespace ff::observe {

// Unwrapped positions (position + image·L) of every particle, n x dim doubles.
void unwrapped_positions(const State& s, std::vector<double>& out);
// Σ_i |unwrapped_i - reference_i|², summed in a fixed order: the same bits for any thread count.
double sum_squared_displacement(const State& s, const std::vector<double>& reference);

}  // namespace ff::observe
