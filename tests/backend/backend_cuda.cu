// The backend test's CUDA half (tests/backend/reductions.h).
#include "core/backend/cuda/loop.cuh"
#include "backend/results.h"

namespace ff::test {

BackendResults cuda_backend_results(std::size_t n) { return backend_results<CudaExec>(n, nullptr); }

}  // namespace ff::test
