// The round trip of one cache line between two threads pinned to CPUs 0 and 1, in ns: about 50
// when the two share a last-level cache, several times that when they do not (two L3 domains of
// one host CPU, or two sockets). A 2-vCPU VM's vCPUs move between such placements as the host
// schedules them, and flipflow's shared-memory threads run ~1.6x slower across L3 domains while
// LAMMPS's MPI ranks do not (bench/README.md, session 40): tools/bench/cpu_vs_lammps.sh probes
// the placement around each run with this program.
//   g++ -O2 -pthread tools/bench/core_to_core.cpp -o core_to_core && ./core_to_core
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

namespace {

alignas(64) std::atomic<int> turn{0};

bool pin(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0;
}

}  // namespace

int main() {
  constexpr int kTrips = 200000;
  bool other_pinned = false;  // written by `other` only, read after the join
  std::thread other([&] {
    other_pinned = pin(1);
    for (int i = 0; i < kTrips; ++i) {
      while (turn.load(std::memory_order_acquire) != 1) {
      }
      turn.store(0, std::memory_order_release);
    }
  });
  const bool pinned = pin(0);
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < kTrips; ++i) {
    turn.store(1, std::memory_order_release);
    while (turn.load(std::memory_order_acquire) != 0) {
    }
  }
  const auto end = std::chrono::steady_clock::now();
  other.join();
  if (!pinned || !other_pinned) {
    std::fprintf(stderr, "core_to_core: cannot pin threads to CPUs 0 and 1\n");
    return 1;
  }
  std::printf("%.1f\n", std::chrono::duration<double, std::nano>(end - start).count() / kTrips);
  return 0;
}
