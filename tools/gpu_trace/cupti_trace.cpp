// GPU timeline tracer: a CUPTI injection library. The CUDA driver loads it when the environment
// names it (CUDA_INJECTION64_PATH=/path/libflipflow_gpu_trace.so) and calls InitializeInjection
// from cuInit. It records every kernel, memcpy and memset the GPU runs, plus a few host-side
// runtime API calls (synchronizations, launches, copies/sets, allocations), and at process exit
// writes them as CSV to $FLIPFLOW_GPU_TRACE (default gpu_trace.csv in the working directory):
//
//   kind,name,start_ns,end_ns,stream,bytes,correlation
//
//   kind         kernel | memcpy | memset | api
//   name         kernel: demangled, return type and parameter list removed, template arguments
//                kept ("ff::for_each_kernel<ff::delaunay::CheckInverted<double>>");
//                memcpy: "HtoD(pageable->device)" (direction, then source and destination memory);
//                memset: "memset(device)"; api: the runtime function ("cudaStreamSynchronize")
//   start_ns, end_ns   CUPTI timestamps (one clock for GPU and host records)
//   stream       CUPTI stream id (empty for api records)
//   bytes        memcpy/memset size (empty otherwise)
//   correlation  CUPTI correlation id: a kernel/memcpy/memset and the api record that issued it
//                share it
//
// FLIPFLOW_GPU_TRACE_API: selected (default: only the calls listed in kApiCalls below are traced,
// which keeps CUPTI's per-call host overhead off everything else), all (every runtime call is
// traced and written), off (no api records).
//
// Records are kept in memory until exit (about 40 bytes each; 100k records are a few MB). Errors
// are reported on stderr with the prefix "gpu_trace:"; the traced program is never stopped.
#include <cupti.h>

#include <cxxabi.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#define FF_EXPORT extern "C" __attribute__((visibility("default")))

namespace {

enum class Kind : uint8_t { kernel, memcpy, memset, api };
const char* kind_name(Kind k) {
  switch (k) {
    case Kind::kernel: return "kernel";
    case Kind::memcpy: return "memcpy";
    case Kind::memset: return "memset";
    case Kind::api: return "api";
  }
  return "?";
}

struct Record {
  uint64_t start, end, bytes;
  uint32_t name;  // index into Tracer::names
  uint32_t stream;
  uint32_t correlation;
  Kind kind;
  bool has_stream, has_bytes;
};

// Runtime calls kept with FLIPFLOW_GPU_TRACE_API=selected (the default): host synchronizations,
// launches, async copies/sets, and the calls that synchronize implicitly or order streams.
const CUpti_CallbackId kApiCalls[] = {
    CUPTI_RUNTIME_TRACE_CBID_cudaStreamSynchronize_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaStreamSynchronize_ptsz_v7000,
    CUPTI_RUNTIME_TRACE_CBID_cudaEventSynchronize_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaDeviceSynchronize_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaMemcpyAsync_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaMemcpyAsync_ptsz_v7000,
    CUPTI_RUNTIME_TRACE_CBID_cudaMemsetAsync_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaMemsetAsync_ptsz_v7000,
    CUPTI_RUNTIME_TRACE_CBID_cudaLaunchKernel_v7000,
    CUPTI_RUNTIME_TRACE_CBID_cudaLaunchKernel_ptsz_v7000,
    CUPTI_RUNTIME_TRACE_CBID___cudaLaunchKernel_v13000,  // what <<<...>>> calls since CUDA 13
    CUPTI_RUNTIME_TRACE_CBID___cudaLaunchKernel_ptsz_v13000,
    CUPTI_RUNTIME_TRACE_CBID_cudaLaunchKernelExC_v11060,
    CUPTI_RUNTIME_TRACE_CBID_cudaLaunchKernelExC_ptsz_v11060,
    CUPTI_RUNTIME_TRACE_CBID_cudaLaunchCooperativeKernel_v9000,
    CUPTI_RUNTIME_TRACE_CBID_cudaLaunchCooperativeKernel_ptsz_v9000,
    CUPTI_RUNTIME_TRACE_CBID_cudaGraphLaunch_v10000,
    CUPTI_RUNTIME_TRACE_CBID_cudaGraphLaunch_ptsz_v10000,
    // implicit synchronizations and stream ordering
    CUPTI_RUNTIME_TRACE_CBID_cudaMemcpy_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaMemcpy_ptds_v7000,
    CUPTI_RUNTIME_TRACE_CBID_cudaMemset_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaMemset_ptds_v7000,
    CUPTI_RUNTIME_TRACE_CBID_cudaMalloc_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaFree_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaMallocAsync_v11020,
    CUPTI_RUNTIME_TRACE_CBID_cudaMallocAsync_ptsz_v11020,
    CUPTI_RUNTIME_TRACE_CBID_cudaFreeAsync_v11020,
    CUPTI_RUNTIME_TRACE_CBID_cudaFreeAsync_ptsz_v11020,
    CUPTI_RUNTIME_TRACE_CBID_cudaStreamWaitEvent_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaStreamWaitEvent_ptsz_v7000,
    CUPTI_RUNTIME_TRACE_CBID_cudaEventRecord_v3020,
    CUPTI_RUNTIME_TRACE_CBID_cudaEventRecord_ptsz_v7000,
};

enum class ApiMode { selected, all, off };

// Everything lives on the heap and is never freed: the atexit handler may run after static
// destructors of this library or of the CUDA runtime, and CUPTI's worker thread may still call.
struct Tracer {
  std::mutex mutex;
  std::vector<Record> records;
  std::vector<std::string> names;
  std::unordered_map<std::string, uint32_t> kernel_names;  // raw (mangled) name -> index
  std::unordered_map<std::string, uint32_t> other_names;   // memcpy/memset/api name -> index
  std::string path;
  ApiMode api_mode = ApiMode::selected;
  bool api_keep[1024] = {};  // by runtime cbid, for ApiMode::selected
  uint64_t dropped = 0, skipped_incomplete = 0, late_records = 0;
  bool written = false;
};
Tracer* g_tracer = nullptr;
std::atomic<bool> g_initialized{false};

constexpr size_t kBufferSize = 8u << 20;
constexpr size_t kAlign = 8;

const char* cupti_error(CUptiResult r) {
  const char* s = nullptr;
  if (cuptiGetResultString(r, &s) != CUPTI_SUCCESS || !s) return "unknown CUPTI error";
  return s;
}

bool check(CUptiResult r, const char* what) {
  if (r == CUPTI_SUCCESS) return true;
  std::fprintf(stderr, "gpu_trace: %s failed: %s (%d)\n", what, cupti_error(r), int(r));
  return false;
}

// "void ns::f<A<int, 2> >(unsigned long, A<int, 2>)" -> "ns::f<A<int, 2>>": the parameter list
// (the last balanced (...) at the end) and a return type (text before the first space outside
// brackets) go; template arguments stay, since they tell the for_each_kernel<F> loops apart.
std::string short_kernel_name(const char* raw) {
  if (!raw || !*raw) return "<unnamed kernel>";
  std::string s = raw;
  if (s.compare(0, 2, "_Z") == 0) {
    int status = 0;
    char* d = abi::__cxa_demangle(raw, nullptr, nullptr, &status);
    if (status == 0 && d) s = d;
    std::free(d);
  }
  for (const char* q : {" const", " volatile", " &&", " &"}) {  // member-function qualifiers
    const size_t n = std::strlen(q);
    if (s.size() > n && s.compare(s.size() - n, n, q) == 0) s.erase(s.size() - n);
  }
  if (!s.empty() && s.back() == ')') {
    int depth = 0;
    for (size_t i = s.size(); i-- > 0;) {
      if (s[i] == ')') ++depth;
      else if (s[i] == '(' && --depth == 0) {
        if (i > 0) s.erase(i);
        break;
      }
    }
  }
  int depth = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (c == '<' || c == '(' || c == '{' || c == '[') ++depth;
    else if (c == '>' || c == ')' || c == '}' || c == ']') --depth;
    else if (c == ' ' && depth == 0) {
      s.erase(0, i + 1);
      break;
    }
  }
  for (size_t p; (p = s.find("> >")) != std::string::npos;) s.erase(p + 1, 1);
  return s;
}

const char* memcpy_kind(uint8_t k) {
  switch (k) {
    case CUPTI_ACTIVITY_MEMCPY_KIND_HTOD: return "HtoD";
    case CUPTI_ACTIVITY_MEMCPY_KIND_DTOH: return "DtoH";
    case CUPTI_ACTIVITY_MEMCPY_KIND_HTOA: return "HtoA";
    case CUPTI_ACTIVITY_MEMCPY_KIND_ATOH: return "AtoH";
    case CUPTI_ACTIVITY_MEMCPY_KIND_ATOA: return "AtoA";
    case CUPTI_ACTIVITY_MEMCPY_KIND_ATOD: return "AtoD";
    case CUPTI_ACTIVITY_MEMCPY_KIND_DTOA: return "DtoA";
    case CUPTI_ACTIVITY_MEMCPY_KIND_DTOD: return "DtoD";
    case CUPTI_ACTIVITY_MEMCPY_KIND_HTOH: return "HtoH";
    case CUPTI_ACTIVITY_MEMCPY_KIND_PTOP: return "PtoP";
    default: return "copy";
  }
}

const char* memory_kind(unsigned k) {
  switch (k) {
    case CUPTI_ACTIVITY_MEMORY_KIND_PAGEABLE: return "pageable";
    case CUPTI_ACTIVITY_MEMORY_KIND_PINNED: return "pinned";
    case CUPTI_ACTIVITY_MEMORY_KIND_DEVICE: return "device";
    case CUPTI_ACTIVITY_MEMORY_KIND_ARRAY: return "array";
    case CUPTI_ACTIVITY_MEMORY_KIND_MANAGED: return "managed";
    case CUPTI_ACTIVITY_MEMORY_KIND_DEVICE_STATIC: return "device_static";
    case CUPTI_ACTIVITY_MEMORY_KIND_MANAGED_STATIC: return "managed_static";
    default: return "unknown";
  }
}

// "__cudaLaunchKernel_ptsz_v13000" -> "cudaLaunchKernel": CUPTI's names may carry the
// per-thread-stream and version suffixes of the cbid enum; the CSV uses the plain function name.
std::string api_name(CUpti_CallbackId cbid) {
  const char* raw = nullptr;
  std::string s;
  if (cuptiGetCallbackName(CUPTI_CB_DOMAIN_RUNTIME_API, cbid, &raw) == CUPTI_SUCCESS && raw) s = raw;
  else s = "runtime_cbid_" + std::to_string(cbid);
  while (!s.empty() && s[0] == '_') s.erase(0, 1);
  const size_t v = s.rfind("_v");
  if (v != std::string::npos && v + 2 < s.size() &&
      s.find_first_not_of("0123456789", v + 2) == std::string::npos)
    s.erase(v);
  for (const char* suffix : {"_ptsz", "_ptds"}) {
    const size_t n = std::strlen(suffix);
    if (s.size() > n && s.compare(s.size() - n, n, suffix) == 0) s.erase(s.size() - n);
  }
  return s;
}

uint32_t intern(std::unordered_map<std::string, uint32_t>& map, const std::string& key,
                const std::string& display) {
  auto it = map.find(key);
  if (it != map.end()) return it->second;
  const uint32_t idx = uint32_t(g_tracer->names.size());
  g_tracer->names.push_back(display);
  map.emplace(key, idx);
  return idx;
}

// The fields memcpy and memset records share (CUpti_ActivityMemcpy6, CUpti_ActivityMemset4).
template <class A>
void fill_transfer(Record& r, Kind kind, const A& m) {
  r.kind = kind;
  r.start = m.start;
  r.end = m.end;
  r.stream = m.streamId;
  r.has_stream = true;
  r.bytes = m.bytes;
  r.has_bytes = true;
  r.correlation = m.correlationId;
}

// Called with g_tracer->mutex held.
void take(const CUpti_Activity* a) {
  Tracer& t = *g_tracer;
  Record r{};
  switch (a->kind) {
    case CUPTI_ACTIVITY_KIND_KERNEL:
    case CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL: {
      auto* k = reinterpret_cast<const CUpti_ActivityKernel10*>(a);
      const std::string raw = k->name ? k->name : "";
      auto it = t.kernel_names.find(raw);
      r.name = it != t.kernel_names.end() ? it->second
                                          : intern(t.kernel_names, raw, short_kernel_name(k->name));
      r.kind = Kind::kernel;
      r.start = k->start;
      r.end = k->end;
      r.stream = k->streamId;
      r.has_stream = true;
      r.correlation = k->correlationId;
      break;
    }
    case CUPTI_ACTIVITY_KIND_MEMCPY: {
      auto* m = reinterpret_cast<const CUpti_ActivityMemcpy6*>(a);
      const std::string name = std::string(memcpy_kind(m->copyKind)) + "(" +
                               memory_kind(m->srcKind) + "->" + memory_kind(m->dstKind) + ")";
      r.name = intern(t.other_names, "memcpy:" + name, name);
      fill_transfer(r, Kind::memcpy, *m);
      break;
    }
    case CUPTI_ACTIVITY_KIND_MEMSET: {
      auto* m = reinterpret_cast<const CUpti_ActivityMemset4*>(a);
      const std::string name = std::string("memset(") + memory_kind(m->memoryKind) + ")";
      r.name = intern(t.other_names, "memset:" + name, name);
      fill_transfer(r, Kind::memset, *m);
      break;
    }
    case CUPTI_ACTIVITY_KIND_RUNTIME: {
      auto* api = reinterpret_cast<const CUpti_ActivityAPI*>(a);
      if (t.api_mode == ApiMode::off) return;
      if (t.api_mode == ApiMode::selected &&
          !(api->cbid < sizeof t.api_keep && t.api_keep[api->cbid]))
        return;
      const std::string key = "api:" + std::to_string(api->cbid);
      auto it = t.other_names.find(key);
      r.name = it != t.other_names.end() ? it->second : intern(t.other_names, key, api_name(api->cbid));
      r.kind = Kind::api;
      r.start = api->start;
      r.end = api->end;
      r.correlation = api->correlationId;
      break;
    }
    default: return;
  }
  if (r.start == 0 || r.end < r.start) {  // incomplete (a forced flush hands those over too)
    ++t.skipped_incomplete;
    return;
  }
  if (t.written) ++t.late_records;
  t.records.push_back(r);
}

void CUPTIAPI buffer_requested(uint8_t** buffer, size_t* size, size_t* max_records) {
  *max_records = 0;
  *buffer = static_cast<uint8_t*>(std::aligned_alloc(kAlign, kBufferSize));
  *size = *buffer ? kBufferSize : 0;
  if (!*buffer) std::fprintf(stderr, "gpu_trace: out of memory for a CUPTI buffer; records will be dropped\n");
}

void CUPTIAPI buffer_completed(CUcontext ctx, uint32_t stream_id, uint8_t* buffer, size_t size,
                               size_t valid) {
  (void)size;
  try {
    if (buffer && valid > 0) {
      std::lock_guard<std::mutex> lock(g_tracer->mutex);
      CUpti_Activity* rec = nullptr;
      for (;;) {
        const CUptiResult r = cuptiActivityGetNextRecord(buffer, valid, &rec);
        if (r == CUPTI_ERROR_MAX_LIMIT_REACHED) break;
        if (r != CUPTI_SUCCESS) {
          check(r, "cuptiActivityGetNextRecord");
          break;
        }
        take(rec);
      }
      size_t dropped = 0;
      if (cuptiActivityGetNumDroppedRecords(ctx, stream_id, &dropped) == CUPTI_SUCCESS && dropped)
        g_tracer->dropped += dropped;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gpu_trace: error while reading a CUPTI buffer: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "gpu_trace: unknown error while reading a CUPTI buffer\n");
  }
  std::free(buffer);
}

void write_csv_field(std::FILE* f, const std::string& s) {
  std::fputc('"', f);
  for (char c : s) {
    if (c == '"') std::fputc('"', f);
    std::fputc(c, f);
  }
  std::fputc('"', f);
}

void at_exit() {
  try {
    check(cuptiActivityFlushAll(CUPTI_ACTIVITY_FLAG_FLUSH_FORCED), "cuptiActivityFlushAll at exit");
    std::lock_guard<std::mutex> lock(g_tracer->mutex);
    Tracer& t = *g_tracer;
    std::vector<Record>& recs = t.records;
    std::stable_sort(recs.begin(), recs.end(),
                     [](const Record& a, const Record& b) { return a.start < b.start; });
    std::FILE* f = std::fopen(t.path.c_str(), "w");
    if (!f) {
      std::fprintf(stderr, "gpu_trace: cannot open '%s' for writing: %s\n", t.path.c_str(),
                   std::strerror(errno));
      return;
    }
    std::fputs("kind,name,start_ns,end_ns,stream,bytes,correlation\n", f);
    size_t counts[4] = {};
    for (const Record& r : recs) {
      ++counts[int(r.kind)];
      std::fputs(kind_name(r.kind), f);
      std::fputc(',', f);
      write_csv_field(f, t.names[r.name]);
      std::fprintf(f, ",%llu,%llu,", (unsigned long long)r.start, (unsigned long long)r.end);
      if (r.has_stream) std::fprintf(f, "%u", r.stream);
      std::fputc(',', f);
      if (r.has_bytes) std::fprintf(f, "%llu", (unsigned long long)r.bytes);
      std::fprintf(f, ",%u\n", r.correlation);
    }
    const bool ok = std::fflush(f) == 0 && !std::ferror(f);
    std::fclose(f);
    t.written = true;
    if (!ok) {
      std::fprintf(stderr, "gpu_trace: error writing '%s'\n", t.path.c_str());
      return;
    }
    std::fprintf(stderr,
                 "gpu_trace: wrote %zu records (%zu kernels, %zu memcpys, %zu memsets, %zu api "
                 "calls) to %s\n",
                 recs.size(), counts[0], counts[1], counts[2], counts[3], t.path.c_str());
    if (t.dropped)
      std::fprintf(stderr, "gpu_trace: warning: CUPTI dropped %llu records (buffers full)\n",
                   (unsigned long long)t.dropped);
    if (t.skipped_incomplete)
      std::fprintf(stderr, "gpu_trace: note: %llu incomplete records (no timestamps) left out\n",
                   (unsigned long long)t.skipped_incomplete);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gpu_trace: error at exit: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "gpu_trace: unknown error at exit\n");
  }
}

// Records that arrive after the CSV was written (e.g. the CUDA runtime's own teardown flushed
// them later) are lost; say so rather than pretend the trace is complete.
void report_late() {
  if (g_tracer && g_tracer->late_records)
    std::fprintf(stderr, "gpu_trace: warning: %llu records arrived after the CSV was written\n",
                 (unsigned long long)g_tracer->late_records);
}

bool enable(CUpti_ActivityKind kind, const char* what) {
  return check(cuptiActivityEnable(kind), what);
}

}  // namespace

FF_EXPORT int InitializeInjection(void) {
  if (g_initialized.exchange(true)) return 1;
  try {
    g_tracer = new Tracer;
    const char* path = std::getenv("FLIPFLOW_GPU_TRACE");
    g_tracer->path = path && *path ? path : "gpu_trace.csv";
    const char* mode = std::getenv("FLIPFLOW_GPU_TRACE_API");
    std::string m = mode ? mode : "";
    if (m == "all") g_tracer->api_mode = ApiMode::all;
    else if (m == "off") g_tracer->api_mode = ApiMode::off;
    else {
      if (!m.empty() && m != "selected")
        std::fprintf(stderr,
                     "gpu_trace: FLIPFLOW_GPU_TRACE_API='%s' is not one of selected, all, off; "
                     "using selected\n",
                     m.c_str());
      m = "selected";
    }
    for (CUpti_CallbackId id : kApiCalls)
      if (id < sizeof g_tracer->api_keep) g_tracer->api_keep[id] = true;

    if (!check(cuptiActivityRegisterCallbacks(buffer_requested, buffer_completed),
               "cuptiActivityRegisterCallbacks")) {
      std::fprintf(stderr, "gpu_trace: tracing disabled\n");
      return 1;  // let the program run untraced
    }
    const bool k = enable(CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL, "enabling kernel records");
    const bool c = enable(CUPTI_ACTIVITY_KIND_MEMCPY, "enabling memcpy records");
    const bool s = enable(CUPTI_ACTIVITY_KIND_MEMSET, "enabling memset records");
    if (!k && !c && !s) {
      std::fprintf(stderr, "gpu_trace: no GPU record kind could be enabled; tracing disabled\n");
      return 1;
    }
    bool ok = k && c && s;
    if (g_tracer->api_mode == ApiMode::all) {
      ok = enable(CUPTI_ACTIVITY_KIND_RUNTIME, "enabling runtime API records") && ok;
    } else if (g_tracer->api_mode == ApiMode::selected) {
      // Only the listed calls: CUPTI's per-call overhead stays off the others (cudaGetLastError
      // after every launch, ...). If CUPTI refuses, fall back to all calls, filtered when read.
      bool each = true;
      for (CUpti_CallbackId id : kApiCalls) {
        const CUptiResult r = cuptiActivityEnableRuntimeApi(id, 1);
        if (r != CUPTI_SUCCESS) {
          std::fprintf(stderr, "gpu_trace: cuptiActivityEnableRuntimeApi(%s) failed: %s (%d)\n",
                       api_name(id).c_str(), cupti_error(r), int(r));
          each = false;
          break;
        }
      }
      if (!each) {
        std::fprintf(stderr, "gpu_trace: falling back to tracing every runtime API call\n");
        ok = enable(CUPTI_ACTIVITY_KIND_RUNTIME, "enabling runtime API records") && ok;
      }
    }
    if (std::atexit(report_late) != 0 || std::atexit(at_exit) != 0)
      std::fprintf(stderr, "gpu_trace: atexit failed; no trace will be written\n");
    std::fprintf(stderr, "gpu_trace: tracing%s, writing %s at exit (api records: %s)\n",
                 ok ? "" : " (some record kinds failed to enable, see above)",
                 g_tracer->path.c_str(), m.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gpu_trace: initialization failed: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "gpu_trace: initialization failed\n");
  }
  return 1;
}
