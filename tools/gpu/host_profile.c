// Where the host's own time goes, on a machine without perf, gdb or valgrind (the GPU machines):
// an LD_PRELOAD library that samples the process's call stacks on its CPU-time clock (SIGPROF,
// every $HOST_PROFILE_US µs of CPU time, default 250; the kernel delivers it at its tick, so at
// most HZ samples a second of CPU) and writes them with the process's memory map to
// $HOST_PROFILE_OUT when the process exits: lines "S TID PC0 PC1 ..." (PC0 the interrupted
// instruction, then its callers by the unwinder, innermost first), then the lines of
// /proc/self/maps prefixed "M ", as they were before each dlclose and at exit. host_profile.py symbolises them (addr2line, against the same
// binaries, e.g. this machine's bundle) and prints the functions by own and by inclusive samples.
//   gcc -O2 -shared -fPIC host_profile.c -o host_profile.so -ldl
//   LD_PRELOAD=./host_profile.so HOST_PROFILE_OUT=prof.txt pipeline bench ... --steps 100000
//   host_profile.py prof.txt [--root BUNDLE]
// Only the sampled thread's stack is taken, so a thread blocked in a wait is never sampled; one
// that spins in a wait (the CUDA driver's default for a short wait) is, in libcuda.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <execinfo.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/syscall.h>
#include <sys/time.h>
#include <ucontext.h>
#include <unistd.h>

enum { kMaxSamples = 1 << 18, kDepth = 24 };
static struct {
  int tid, depth;
  void* pc[kDepth];
} samples[kMaxSamples];
static volatile int nsamples;
static const char* out_path;
// The memory maps taken before each dlclose (the plugins are unloaded before the process exits,
// and their samples' addresses must still be found) and at exit.
static char* maps_text;
static size_t maps_len;

static void take_maps(void) {
  FILE* m = fopen("/proc/self/maps", "r");
  if (!m) return;
  char line[4096];
  while (fgets(line, sizeof line, m)) {
    const size_t k = strlen(line);
    char* grown = realloc(maps_text, maps_len + k + 3);
    if (!grown) break;
    maps_text = grown;
    memcpy(maps_text + maps_len, "M ", 2);
    memcpy(maps_text + maps_len + 2, line, k);
    maps_len += k + 2;
  }
  fclose(m);
}

int dlclose(void* handle) {
  static int (*real)(void*);
  if (!real) real = (int (*)(void*))dlsym(RTLD_NEXT, "dlclose");
  if (out_path) take_maps();
  return real(handle);
}

static void on_prof(int sig, siginfo_t* info, void* ctx) {
  (void)sig;
  (void)info;
  const int i = __atomic_fetch_add(&nsamples, 1, __ATOMIC_RELAXED);
  if (i >= kMaxSamples) return;
  void* frames[kDepth + 3];
  // The unwinder walks through the signal frame (glibc's __restore_rt has its CFI): frames[0]
  // is this handler, then the trampoline, then the interrupted function's callers.
  const int n = backtrace(frames, kDepth + 3);
  const ucontext_t* uc = (const ucontext_t*)ctx;
  samples[i].tid = (int)syscall(SYS_gettid);
  samples[i].pc[0] = (void*)uc->uc_mcontext.gregs[REG_RIP];
  int d = 1;
  for (int k = 3; k < n && d < kDepth; ++k) samples[i].pc[d++] = frames[k];  // past handler, trampoline, PC0
  samples[i].depth = d;
}

__attribute__((constructor)) static void start(void) {
  out_path = getenv("HOST_PROFILE_OUT");
  if (!out_path) return;
  void* warm[4];
  backtrace(warm, 4);  // loads libgcc_s now, not inside the first signal
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_sigaction = on_prof;
  sa.sa_flags = SA_SIGINFO | SA_RESTART;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGPROF, &sa, NULL);
  const char* us = getenv("HOST_PROFILE_US");
  const long period = us ? atol(us) : 250;
  struct itimerval it = {{0, period}, {0, period}};
  setitimer(ITIMER_PROF, &it, NULL);
}

__attribute__((destructor)) static void stop(void) {
  if (!out_path) return;
  struct itimerval off = {{0, 0}, {0, 0}};
  setitimer(ITIMER_PROF, &off, NULL);
  // A process that took no samples (a wrapper such as timeout, which inherits the preload) leaves
  // the file to the one that did.
  const int n = nsamples < kMaxSamples ? nsamples : kMaxSamples;
  if (n == 0) return;
  FILE* f = fopen(out_path, "w");
  if (!f) return;
  for (int i = 0; i < n; ++i) {
    fprintf(f, "S %d", samples[i].tid);
    for (int k = 0; k < samples[i].depth; ++k) fprintf(f, " %p", samples[i].pc[k]);
    fputc('\n', f);
  }
  take_maps();
  if (maps_text) fwrite(maps_text, 1, maps_len, f);
  fclose(f);
}
