// "Not computed yet": a real field that no stage has written (Field::version() 0, never acquired
// for writing: a force, voronoi.area before the first step) holds the zeros it was allocated
// with, which read as values. Outputs of the initial state say NaN instead: observe.h5md's frame
// 0, observe.mean, a decomposed team's first gather (core/run/domain.cpp). nvcc-clean.
#pragma once
#include <algorithm>
#include <cstddef>
#include <limits>

#include "core/backend/field.h"

namespace ff {

inline bool is_real(DType t) { return t == DType::f64 || t == DType::f32; }

// Whether `f` is a real field nothing has written yet.
inline bool not_computed(const Field& f) { return f.version() == 0 && is_real(f.dtype()); }

// Sets `scalars` values of real type `dtype` at `data` to NaN.
inline void fill_not_computed(void* data, DType dtype, std::size_t scalars) {
  if (dtype == DType::f64) std::fill_n(static_cast<double*>(data), scalars, std::numeric_limits<double>::quiet_NaN());
  else std::fill_n(static_cast<float*>(data), scalars, std::numeric_limits<float>::quiet_NaN());
}

}  // namespace ff
