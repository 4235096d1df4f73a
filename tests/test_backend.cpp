// The backend object (core/backend: CpuExec, CudaExec, memory.h): reductions equal a serial
// loop (and so each other, bit for bit: they are integer), a reused Reduction starts from its
// identity, fresh scratch memory reads zero and keeps its contents, counters read the same
// synchronously and deferred; a thread's time blocked on the device is counted for it alone; a
// State finds its fields by a C string as by a std::string, through a reused buffer too.
#include <oneapi/tbb/global_control.h>

#include <catch2/catch.hpp>

#include "backend/results.h"
#include "core/backend/exec_cpu.h"
#include "core/backend/field.h"
#include "core/backend/host_wait.h"
#include "core/stage/state.h"
#include "support/backends.h"

#include <chrono>
#include <cstdio>
#include <thread>

#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime.h>

#include <vector>
#endif

using namespace ff;
using namespace ff::test;

namespace ff::test {
BackendResults cpu_backend_results(std::size_t n) { return backend_results<CpuExec>(n, nullptr); }
}  // namespace ff::test

namespace {
BackendResults serial(std::size_t n) {
  BackendResults r;
  for (std::size_t i = 0; i < n; ++i) {
    r.max = std::max(r.max, Scrambled{}(i));
    r.sum += Square{}(i);
    r.count += MultipleOf7{}(i) ? 1 : 0;
    if (i < n / 2) r.max_again = std::max(r.max_again, Scrambled{}(i));
    r.odd_sync += ((unsigned(i) + 3) & 1u) ? 1 : 0;
  }
  r.odd_deferred = r.odd_sync;
  r.first_scratch = 0;
  r.kept = 5 + 4;
  return r;
}

void check_equal(const BackendResults& a, const BackendResults& b) {
  CHECK(a.max == b.max);
  CHECK(a.sum == b.sum);
  CHECK(a.count == b.count);
  CHECK(a.max_again == b.max_again);
  CHECK(a.odd_sync == b.odd_sync);
  CHECK(a.odd_deferred == b.odd_deferred);
  CHECK(a.first_scratch == b.first_scratch);
  CHECK(a.kept == b.kept);
}
}  // namespace

TEST_CASE("backend reductions, scratch and counters equal a serial loop on every backend", "[backend]") {
  // 3 sizes: below one TBB grain / CUDA block, a few blocks, and many (2^22 + 5: the sum of
  // squares passes 2^64 and wraps, which the closed form below checks exactly).
  const std::size_t n = GENERATE(std::size_t(100), std::size_t(70001), std::size_t((1u << 22) + 5));
  CAPTURE(n);
  const BackendResults expected = serial(n);
  const unsigned __int128 m = n;
  CHECK(expected.sum == std::uint64_t((m - 1) * m * (2 * m - 1) / 6));  // the serial loop: Σ i² mod 2^64
  for (int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    check_equal(cpu_backend_results(n), expected);
  }
#ifdef FLIPFLOW_HAVE_CUDA
  if (have_cuda("CudaExec reductions, scratch and counters")) check_equal(cuda_backend_results(n), expected);
#endif
}

#ifdef FLIPFLOW_HAVE_CUDA
// Two stages on two streams that both read a field valid only on the host (the first step, a
// resume, after a host stage) are not ordered with each other: the first acquire uploads on its
// stream, the second finds the field valid on the device. The upload must have landed by then.
// Here a sleeping host function holds the first reader's stream; until session 33 the upload
// waited behind it while the second reader copied the device buffer, still unwritten.
TEST_CASE("a field uploaded for one stream's reader is on the device for another stream's", "[backend][cuda]") {
  if (!have_cuda("two unordered readers of a host-written field")) return;
  const std::size_t n = 4096;
  Field f("x", DType::f64, 1, n);
  f.acquire(Where::host, Mode::write);
  for (std::size_t i = 0; i < n; ++i) f.host<double>()[i] = 1.5 + double(i);
  cudaStream_t first = nullptr, second = nullptr;
  REQUIRE(cudaStreamCreateWithFlags(&first, cudaStreamNonBlocking) == cudaSuccess);
  REQUIRE(cudaStreamCreateWithFlags(&second, cudaStreamNonBlocking) == cudaSuccess);
  auto hold = [](void*) { std::this_thread::sleep_for(std::chrono::milliseconds(300)); };
  REQUIRE(cudaLaunchHostFunc(first, hold, nullptr) == cudaSuccess);
  f.acquire(Where::device, Mode::read, reinterpret_cast<CUstream_st*>(first));
  f.acquire(Where::device, Mode::read, reinterpret_cast<CUstream_st*>(second));
  std::vector<double> seen(n, 0.0);
  REQUIRE(cudaMemcpyAsync(seen.data(), f.device_raw(), f.bytes(), cudaMemcpyDeviceToHost, second) == cudaSuccess);
  REQUIRE(cudaStreamSynchronize(second) == cudaSuccess);
  REQUIRE(cudaStreamSynchronize(first) == cudaSuccess);
  cudaStreamDestroy(first);
  cudaStreamDestroy(second);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < n; ++i) wrong += seen[i] != 1.5 + double(i);
  CHECK(wrong == 0);
}
#endif

// `pipeline bench`'s host's own time a step is a pass's wall time less the thread's waits
// (core/backend/host_wait.h): a wait counts its whole duration, for the thread that waited only.
TEST_CASE("a thread's waits are counted for that thread", "[backend]") {
  using std::chrono::milliseconds;
  const double before = host_wait_seconds();
  {
    const HostWait waiting;
    std::this_thread::sleep_for(milliseconds(30));
  }
  const double mine = host_wait_seconds() - before;
  CHECK(mine >= 0.030);
  CHECK(mine < 1.0);
  double other = -1;
  std::thread([&] {
    const double t0 = host_wait_seconds();
    {
      const HostWait waiting;
      std::this_thread::sleep_for(milliseconds(50));
    }
    other = host_wait_seconds() - t0;
  }).join();
  CHECK(other >= 0.050);
  CHECK(host_wait_seconds() - before == mine);  // the other thread's wait is not this one's
  std::this_thread::sleep_for(milliseconds(20));  // outside a HostWait: not a wait
  CHECK(host_wait_seconds() - before == mine);
}

#ifdef FLIPFLOW_HAVE_CUDA
// The CUDA backend's waits for stage counters (a fence: an event) are HostWaits: here the fence
// waits behind a host function that holds its stream for 100 ms.
TEST_CASE("the CUDA backend's waits for the device are counted", "[backend][cuda]") {
  if (!have_cuda("the host's waits for the device")) return;
  const MemoryOps& ops = cuda_memory();
  cudaStream_t s = nullptr;
  REQUIRE(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking) == cudaSuccess);
  void* fence = ops.fence_create();
  auto hold = [](void*) { std::this_thread::sleep_for(std::chrono::milliseconds(100)); };
  REQUIRE(cudaLaunchHostFunc(s, hold, nullptr) == cudaSuccess);
  ops.fence_record(fence, reinterpret_cast<CUstream_st*>(s));
  const double before = host_wait_seconds();
  ops.fence_wait(fence);
  const double waited = host_wait_seconds() - before;
  CHECK(waited >= 0.080);  // (the host function started before the record, so a little less than 100 ms)
  CHECK(waited < 5.0);
  ops.fence_destroy(fence);
  cudaStreamDestroy(s);
}
#endif

TEST_CASE("State::field by a C string: the same field as by std::string, also when a buffer is reused",
          "[backend][state]") {
  State s(2, Precision::f64, 10);
  s.add_field("alpha.long_field_name", DType::i32, 1, 10);
  s.add_field("beta", DType::f64, 3, 4);
  for (int round = 0; round < 3; ++round) {  // found, then remembered by address
    CHECK(&s.field(fields::position) == &s.field(std::string(fields::position)));
    CHECK(&s.field("beta") == &s.field(std::string("beta")));
    CHECK(s.field("alpha.long_field_name").name() == "alpha.long_field_name");
  }
  // One buffer, three names in turn: the remembered field of the first must not answer the others.
  char buffer[32];
  for (const char* name : {"beta", "alpha.long_field_name", "position", "beta"}) {
    std::snprintf(buffer, sizeof buffer, "%s", name);
    CHECK(s.field(static_cast<const char*>(buffer)).name() == name);
    const State& cs = s;
    CHECK(cs.field(static_cast<const char*>(buffer)).name() == name);
  }
  std::snprintf(buffer, sizeof buffer, "%s", "gamma");
  CHECK_THROWS_AS(s.field(static_cast<const char*>(buffer)), std::out_of_range);
}
