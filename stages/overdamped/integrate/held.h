// In a decomposed team (docs/multi-gpu.md) an integrator moves only the owned particles
// [0, n_owned). When the step reads the previous values from the rollback snapshot's copy
// (StepContext::will_overwrite), the field it writes holds stale storage: the entries of the
// other particles the rank holds (ghosts, and the fixed vertices a Delaunay pipeline adds beyond
// the band, Scheduling::fills_gap) are copied over so that the field holds them as before the
// step (a ghost is refreshed by its owner later; a fill vertex never is). nvcc-clean.
#pragma once
#include <cstddef>

#include "core/backend/memory.h"
#include "core/stage/state.h"

namespace ff::overdamped {

inline void keep_unowned(State& s, Field& in, const char* name, Where where, const MemoryOps& mem,
                         CUstream_st* stream) {
  Field& out = s.field(name);
  if (&in == &out || s.n_owned() == s.n() || out.count() == 0) return;
  const std::size_t entry = out.bytes() / out.count();
  const std::size_t skip = s.n_owned() * entry;
  auto* dst = static_cast<unsigned char*>(where == Where::device ? out.device_raw() : out.host_raw());
  const auto* src = static_cast<const unsigned char*>(where == Where::device ? in.device_raw() : in.host_raw());
  mem.copy(dst + skip, src + skip, out.bytes() - skip, stream);
}

}  // namespace ff::overdamped
