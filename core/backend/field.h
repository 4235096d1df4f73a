// A named per-element buffer (per particle, per edge, ...) with a host copy and, when the CUDA
// backend is on, a device mirror. Coherence is tracked per side: a stage *acquires* a field
// where (host/device) and how (read/write) it needs it, and the field copies only when the
// side asked for is stale. Nothing here copies per step unless a stage on the other side
// wrote the field. nvcc-clean.
#pragma once
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "core/base/types.h"

namespace ff {

enum class Where : std::uint8_t { host, device };
enum class Mode : std::uint8_t { read, write, readwrite };

inline bool writes(Mode m) { return m != Mode::read; }
inline bool reads(Mode m) { return m != Mode::write; }
const char* to_string(Where w);
// Where a backend's stages keep their data: the host for the CPU, the device for CUDA.
inline Where side_of(Backend b) { return b == Backend::cuda ? Where::device : Where::host; }
const char* to_string(Mode m);

class DeviceBuffer;  // core/backend/cuda/device_buffer.h (CUDA builds only)

class Field {
 public:
  Field(std::string name, DType dtype, int components, std::size_t count);
  ~Field();
  Field(const Field&) = delete;
  Field& operator=(const Field&) = delete;

  const std::string& name() const { return name_; }
  DType dtype() const { return dtype_; }
  int components() const { return components_; }
  std::size_t count() const { return count_; }
  std::size_t size() const { return count_ * std::size_t(components_); }  // scalars
  std::size_t bytes() const { return size() * dtype_size(dtype_); }

  // Host data. Typed access checks the element type; it does not synchronize: call
  // acquire(Where::host, ...) first (the scheduler does this from a stage's declared access).
  template <class T> T* host() { check_type(dtype_of<T>()); return static_cast<T*>(host_raw()); }
  template <class T> const T* host() const { check_type(dtype_of<T>()); return static_cast<const T*>(host_); }
  void* host_raw();

  // Device mirror, allocated on first use. Throws in a build without CUDA.
  template <class T> T* device() { check_type(dtype_of<T>()); return static_cast<T*>(device_raw()); }
  void* device_raw();

  // The data on side `where`: host<T>() or device<T>() (no synchronization either).
  template <class T> T* data(Where where) { return where == Where::device ? device<T>() : host<T>(); }
  // The data on the side of the stage running in `ctx` (a StepContext, core/stage/stage.h): the
  // device for a CUDA stage, the host for a CPU one (a host-only stage that runs in a CUDA run
  // asks host<T>()).
  template <class T, class Context> T* data(const Context& ctx) { return data<T>(side_of(ctx.backend)); }

  // Make the `where` side current for `mode`, copying on `stream` if that side is stale
  // (stream-ordered: later work on `stream` sees the data). A write marks the other side stale.
  void acquire(Where where, Mode mode, CUstream_st* stream = nullptr);
  bool valid_on(Where w) const { return w == Where::host ? host_valid_ : device_valid_; }
  // Bumped by every acquire for writing, mark_written and resize: equal versions mean nothing
  // wrote the field in between (a stage may skip work that depends only on unchanged data).
  std::uint64_t version() const { return version_.load(std::memory_order_relaxed); }
  // Declare that the side `where` was just written outside acquire() (e.g. by a restore).
  void mark_written(Where where);

  // Exchange the contents of two fields of the same element type, components and count (host
  // and device storage with their coherence), without copying: the rollback snapshot's copy of
  // a field that a stage is about to overwrite completely (Snapshot::take_before_overwrite).
  // Device pointers taken before it point into the other field afterwards. Bumps both versions.
  void swap_contents(Field& other);

  // Change the element count. Contents of the first min(old, new) elements are kept on the
  // host side (the field is brought to the host first).
  void resize(std::size_t count);
  // Change the element count without keeping the contents, for a caller that writes every
  // element next (a rollback snapshot's copy of a field whose count a decomposed team's
  // migration changed): nothing is copied to the host, and the device storage is kept when it
  // is large enough. The contents are undefined until written.
  void resize_discarding(std::size_t count);
  // CUDA builds: `buffer` (at least count elements, written by the caller) becomes the device
  // storage and `count` the element count; the device side is current, the host side stale (its
  // storage resized, not copied). Returns the storage it replaces (null if none), for the caller
  // to reuse. A decomposed team's migration on the device (core/run/domain.h).
  std::unique_ptr<DeviceBuffer> adopt_device(std::unique_ptr<DeviceBuffer> buffer, std::size_t count);

 private:
  void check_type(DType asked) const;
  std::string device_label() const;  // the field in an out-of-memory error

  std::string name_;
  DType dtype_;
  int components_;
  std::size_t count_;
  void* host_ = nullptr;  // 64-byte aligned
  std::unique_ptr<DeviceBuffer> device_;
  bool host_valid_ = true;
  bool device_valid_ = false;
  std::atomic<std::uint64_t> version_{0};
  std::mutex mutex_;  // concurrent stages may acquire the same field
};

}  // namespace ff
