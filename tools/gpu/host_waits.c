// The host's side of a step on CUDA: an LD_PRELOAD library that times the CUDA runtime calls a
// run makes (libflipflow and the plugins link libcudart.so dynamically, so preloading intercepts
// them) and writes every call to $HOST_WAITS_OUT when the process exits, one line each:
//   KIND t0 t1 KERNEL    t0, t1: ns (CLOCK_MONOTONIC); KERNEL: a launch's host stub (its address,
//                        and its symbol where dladdr finds one), else (nil) -
// KIND: L cudaLaunchKernelExC, K __cudaLaunchKernel (a <<<>>> launch); the waits E cudaEventSynchronize, S cudaStreamSynchronize,
// D cudaDeviceSynchronize; the other calls R cudaEventRecord, W cudaStreamWaitEvent,
// M cudaMemcpyAsync, Z cudaMemsetAsync, G cudaGraphLaunch, Q cudaEventQuery.
// host_waits.py turns a `pipeline bench` run's file into the host's own time a step (the step's
// period minus its waits) and the typical step's calls in order (call_lib.sh's host_waits runs
// both on the GPU machine). A timing costs two clock reads (~50 ns) a call.
//   gcc -O2 -shared -fPIC host_waits.c -o host_waits.so -ldl
//   LD_PRELOAD=./host_waits.so HOST_WAITS_OUT=calls.txt pipeline bench ... --sizes N --steps S --warmup W
//   host_waits.py calls.txt W S
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

enum { kMax = 1 << 22 };
static struct { char kind; long long t0, t1; const void* f; } rec[kMax];
static int nrec;

static long long now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1000000000LL + ts.tv_nsec;
}
static void add(char k, long long t0, long long t1, const void* f) {
  if (nrec < kMax) {
    rec[nrec].kind = k;
    rec[nrec].t0 = t0;
    rec[nrec].t1 = t1;
    rec[nrec].f = f;
    ++nrec;
  }
}
// One wrapper per call: the real function found once, the call timed, a record of kind K (KERNEL:
// the launched kernel's host stub, else 0).
#define WRAP(K, KERNEL, NAME, PARAMS, ARGS)                      \
  int NAME PARAMS {                                             \
    static int(*real) PARAMS;                                   \
    if (!real) real = (int(*) PARAMS)dlsym(RTLD_NEXT, #NAME);   \
    const long long t0 = now();                                 \
    const int r = real ARGS;                                    \
    add(K, t0, now(), KERNEL);                                  \
    return r;                                                   \
  }
// A <<<>>> launch: nvcc's stub calls the runtime's __cudaLaunchKernel (cudaLaunchKernel's arguments).
typedef struct {
  unsigned x, y, z;
} Dim3;
WRAP('L', f, cudaLaunchKernelExC, (const void* cfg, const void* f, void** args), (cfg, f, args))
WRAP('K', f, __cudaLaunchKernel, (const void* f, Dim3 grid, Dim3 block, void** args, size_t shared, void* stream),
     (f, grid, block, args, shared, stream))
WRAP('E', 0, cudaEventSynchronize, (void* e), (e))
WRAP('S', 0, cudaStreamSynchronize, (void* s), (s))
WRAP('D', 0, cudaDeviceSynchronize, (void), ())
WRAP('R', 0, cudaEventRecord, (void* e, void* s), (e, s))
WRAP('W', 0, cudaStreamWaitEvent, (void* s, void* e, unsigned f), (s, e, f))
WRAP('M', 0, cudaMemcpyAsync, (void* d, const void* src, size_t n, int k, void* s), (d, src, n, k, s))
WRAP('Z', 0, cudaMemsetAsync, (void* d, int v, size_t n, void* s), (d, v, n, s))
WRAP('G', 0, cudaGraphLaunch, (void* g, void* s), (g, s))
WRAP('Q', 0, cudaEventQuery, (void* e), (e))

__attribute__((destructor)) static void dump(void) {
  const char* path = getenv("HOST_WAITS_OUT");
  fprintf(stderr, "host_waits: pid %d, %d records to %s\n", (int)getpid(), nrec, path ? path : "(none)");
  if (!nrec) return;  // a child process (pipeline runs probes): the file is its parent's
  FILE* f = path ? fopen(path, "w") : NULL;
  if (!f) return;
  for (int i = 0; i < nrec; ++i) {
    Dl_info info;
    const char* name = rec[i].f && dladdr(rec[i].f, &info) && info.dli_sname ? info.dli_sname : "-";
    fprintf(f, "%c %lld %lld %p %s\n", rec[i].kind, rec[i].t0, rec[i].t1, rec[i].f, name);
  }
  fclose(f);
}
