#include "core/rollback.h"

#include <algorithm>
#include <cstring>

#ifdef FLIPFLOW_HAVE_CUDA
#include "core/cuda/check.h"
#endif
#include "core/error.h"

namespace ff {

void copy_field_contents(Field& dst, Field& src, Where where, CUstream_st* stream) {
  if (dst.count() != src.count()) dst.resize(src.count());
  if (where == Where::host) {
    src.acquire(Where::host, Mode::read);
    dst.acquire(Where::host, Mode::write);
    if (src.bytes()) std::memcpy(dst.host_raw(), src.host_raw(), src.bytes());
    return;
  }
#ifdef FLIPFLOW_HAVE_CUDA
  src.acquire(Where::device, Mode::read, stream);
  dst.acquire(Where::device, Mode::write, stream);
  if (src.bytes())
    FF_CUDA_CHECK(cudaMemcpyAsync(dst.device_raw(), src.device_raw(), src.bytes(), cudaMemcpyDeviceToDevice, stream),
                  "copying a field for a rollback snapshot");
#else
  (void)stream;
  throw RunError("device snapshot in a build without CUDA");
#endif
}

void Snapshot::take(State& state, CUstream_st* stream) {
  if (copies_.empty()) {
    for (auto& name : names_) {
      Field& f = state.field(name);
      copies_.push_back(std::make_unique<Field>(name, f.dtype(), f.components(), f.count()));
      sides_.push_back(Where::host);
    }
  }
  for (std::size_t i = 0; i < names_.size(); ++i) {
    Field& f = state.field(names_[i]);
    // Keep the copy where the data is current: on the device for a CUDA run, so a snapshot
    // never crosses the bus.
    sides_[i] = f.valid_on(Where::device) && !f.valid_on(Where::host) ? Where::device : Where::host;
    if (f.valid_on(Where::device) && f.valid_on(Where::host)) sides_[i] = Where::device;
#ifndef FLIPFLOW_HAVE_CUDA
    sides_[i] = Where::host;
#endif
    copy_field_contents(*copies_[i], f, sides_[i], stream);
  }
}

void Snapshot::restore(State& state, CUstream_st* stream) {
  for (std::size_t i = 0; i < names_.size(); ++i) {
    Field& f = state.field(names_[i]);
    copy_field_contents(f, *copies_[i], sides_[i], stream);
    f.mark_written(sides_[i]);
  }
}

bool DtController::halve() {
  streak_ = 0;
  if (current_ / 2 < min_ * (1 - 1e-12)) return false;
  current_ /= 2;
  return true;
}

void DtController::accepted() {
  if (current_ >= nominal_) return;
  if (++streak_ >= grow_after_) {
    current_ = std::min(current_ * 2, nominal_);
    streak_ = 0;
  }
}

}  // namespace ff
