// Out of GPU memory (issue 19, item 6): the error names what was being allocated (the field with
// its element count, N for a per-particle field, or a stage's scratch array), the bytes, and what
// the device has free, and says what to do; the error is not sticky, so the run can still end
// cleanly (finish its observers, keep its output). Needs a GPU: skips visibly without one.
#include <catch2/catch.hpp>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/backend/cuda/device_buffer.h"
#include "core/backend/field.h"
#include "core/backend/memory.h"
#include "core/base/error.h"
#include "support/backends.h"

using Catch::Contains;

namespace {
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ff::RunError& e) {
    return e.what();
  }
  return "(no error)";
}
}  // namespace

TEST_CASE("out of GPU memory names the allocation and the bytes", "[backend][cuda]") {
  if (!ff::test::have_cuda("out-of-GPU-memory messages")) return;
  const std::size_t huge = std::size_t(1) << 50;  // 1 PiB: more than any GPU has

  const std::string buffer = error_of([&] { ff::DeviceBuffer b(huge, "field 'position' (test)"); });
  CHECK_THAT(buffer, Contains("out of GPU memory: 1125899906842624 bytes (1073741824 MiB) for field 'position' (test)"));
  CHECK_THAT(buffer, Contains("MiB free of"));
  CHECK_THAT(buffer, Contains("lower system.N"));

  const std::string scratch = error_of([&] { ff::cuda_memory().alloc(huge); });
  CHECK_THAT(scratch, Contains("1125899906842624 bytes") && Contains("a stage's scratch array"));

  // A field that meets a full GPU: fill the device, then ask for a 64 KiB field.
  std::vector<std::unique_ptr<ff::DeviceBuffer>> filler;
  for (std::size_t chunk : {std::size_t(1) << 30, std::size_t(1) << 24, std::size_t(1) << 20, std::size_t(1) << 16}) {
    for (;;) {
      try {
        filler.push_back(std::make_unique<ff::DeviceBuffer>(chunk, "filler"));
      } catch (const ff::RunError&) {
        break;
      }
    }
  }
  ff::Field position("position", ff::DType::f64, 2, 4096);
  const std::string field = error_of([&] { position.device_raw(); });
  filler.clear();
  CHECK_THAT(field, Contains("out of GPU memory: 65536 bytes"));
  CHECK_THAT(field, Contains("field 'position' (4096 elements = N for a per-particle field, 2 x f64 each)"));
  // Not sticky: with the memory back, the same field allocates.
  CHECK_NOTHROW(position.device_raw());
}
