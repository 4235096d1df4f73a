#include "core/backend/field.h"

#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include <sys/mman.h>

#include "core/base/error.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "core/backend/cuda/device_buffer.h"
#else
namespace ff {
class DeviceBuffer {};  // never allocated in a build without CUDA
}  // namespace ff
#endif

namespace ff {

const char* to_string(Where w) { return w == Where::host ? "host" : "device"; }
const char* to_string(Mode m) {
  return m == Mode::read ? "read" : m == Mode::write ? "write" : "readwrite";
}

namespace {
// Buffers of at least a huge page are aligned to one and offered to the kernel for transparent
// huge pages (Linux, THP in "madvise" mode as on Debian): the edge loops touch a large field at
// scattered places, and with 4 KiB pages nearly every such access also misses the TLB.
constexpr std::size_t kHugePage = std::size_t(2) << 20;

void* aligned_storage(std::size_t bytes, bool zero) {
  if (bytes == 0) return nullptr;
  const bool huge = bytes >= kHugePage;
  const std::size_t align = huge ? kHugePage : 64;
  const std::size_t rounded = (bytes + align - 1) / align * align;
  void* p = std::aligned_alloc(align, rounded);
  if (!p) throw RunError("out of host memory allocating " + std::to_string(bytes) + " bytes");
#ifdef MADV_HUGEPAGE
  if (huge) madvise(p, rounded, MADV_HUGEPAGE);  // advice only: failure leaves 4 KiB pages
#endif
  if (zero) std::memset(p, 0, rounded);
  return p;
}
void* aligned_zeroed(std::size_t bytes) { return aligned_storage(bytes, true); }
}  // namespace

Field::Field(std::string name, DType dtype, int components, std::size_t count)
    : name_(std::move(name)), dtype_(dtype), components_(components), count_(count) {
  host_ = aligned_zeroed(bytes());
}

Field::~Field() { std::free(host_); }

void Field::check_type(DType asked) const {
  if (asked != dtype_)
    throw std::logic_error("field '" + name_ + "' holds " + to_string(dtype_) +
                           " but was accessed as " + to_string(asked));
}

void* Field::host_raw() { return host_; }

// How an out-of-memory error names this field: its name, its element count (N for a
// per-particle field) and layout.
std::string Field::device_label() const {
  return "field '" + name_ + "' (" + std::to_string(count_) + " elements = N for a per-particle field, " +
         std::to_string(components_) + " x " + to_string(dtype_) + " each)";
}

#ifdef FLIPFLOW_HAVE_CUDA

void* Field::device_raw() {
  if (!device_) device_ = std::make_unique<DeviceBuffer>(bytes(), device_label());
  return device_->data();
}

void Field::acquire(Where where, Mode mode, CUstream_st* stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (writes(mode)) ++version_;
  if (where == Where::device) {
    if (!device_) device_ = std::make_unique<DeviceBuffer>(bytes(), device_label());
    if (reads(mode) && !device_valid_) device_->upload(host_, bytes(), stream);
    device_valid_ = true;
    if (writes(mode)) host_valid_ = false;
  } else {
    if (reads(mode) && !host_valid_ && device_) device_->download(host_, bytes(), stream);
    host_valid_ = true;
    if (writes(mode)) device_valid_ = false;
  }
}

std::unique_ptr<DeviceBuffer> Field::adopt_device(std::unique_ptr<DeviceBuffer> buffer, std::size_t count) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::size_t need = count * std::size_t(components_) * dtype_size(dtype_);
  if (!buffer || buffer->bytes() < need)
    throw std::logic_error("field '" + name_ + "': adopt_device with a buffer smaller than " + std::to_string(need) +
                           " bytes");
  ++version_;
  if (count != count_) {
    std::free(host_);
    host_ = aligned_storage(need, false);  // stale until the next acquire on the host copies into it
    count_ = count;
  }
  std::swap(device_, buffer);
  device_valid_ = true;
  host_valid_ = false;
  return buffer;
}

#else

std::unique_ptr<DeviceBuffer> Field::adopt_device(std::unique_ptr<DeviceBuffer>, std::size_t) {
  throw RunError("field '" + name_ + "': this flipflow was built without CUDA");
}

void* Field::device_raw() {
  throw RunError("field '" + name_ + "': this flipflow was built without CUDA");
}

void Field::acquire(Where where, Mode mode, CUstream_st*) {
  if (where == Where::device)
    throw RunError("field '" + name_ + "': this flipflow was built without CUDA");
  if (writes(mode)) ++version_;
}

#endif

void Field::mark_written(Where where) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++version_;
  host_valid_ = where == Where::host;
  device_valid_ = where == Where::device;
}

void Field::swap_contents(Field& other) {
  if (&other == this) return;
  if (other.dtype_ != dtype_ || other.components_ != components_ || other.count_ != count_)
    throw std::logic_error("swap_contents: fields '" + name_ + "' and '" + other.name_ + "' differ in shape");
  std::scoped_lock lock(mutex_, other.mutex_);
  std::swap(host_, other.host_);
  std::swap(device_, other.device_);
  std::swap(host_valid_, other.host_valid_);
  std::swap(device_valid_, other.device_valid_);
  ++version_;
  ++other.version_;
}

void Field::resize_discarding(std::size_t count) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (count == count_) return;
  ++version_;
  const std::size_t need = count * std::size_t(components_) * dtype_size(dtype_);
  std::free(host_);
  host_ = aligned_storage(need, false);
  count_ = count;
#ifdef FLIPFLOW_HAVE_CUDA
  if (device_ && device_->bytes() < need) device_.reset();
#endif
  host_valid_ = true;  // as resize leaves it: an acquire for writing on either side copies nothing
  device_valid_ = false;
}

void Field::resize(std::size_t count) {
  if (count == count_) return;
  acquire(Where::host, Mode::readwrite);  // bumps the version
  const std::size_t keep = std::min(count, count_) * components_ * dtype_size(dtype_);
  void* fresh = aligned_zeroed(count * components_ * dtype_size(dtype_));
  if (keep) std::memcpy(fresh, host_, keep);
  std::free(host_);
  host_ = fresh;
  count_ = count;
#ifdef FLIPFLOW_HAVE_CUDA
  device_.reset();
#endif
  host_valid_ = true;
  device_valid_ = false;
}

}  // namespace ff
