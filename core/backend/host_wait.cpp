#include "core/backend/host_wait.h"

#include <chrono>

namespace ff {

namespace {
thread_local long long waited_ns = 0;

long long now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

double host_wait_seconds() { return 1e-9 * double(waited_ns); }

HostWait::HostWait() : start_ns_(now_ns()) {}
HostWait::~HostWait() { waited_ns += now_ns() - start_ns_; }

}  // namespace ff
