// An empty kernel on a stream: what a no-op stage costs on the GPU (one launch).
#pragma once
struct CUstream_st;
namespace ff {
void launch_empty_kernel(CUstream_st* stream);
}
