// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "stages/delaunay/lawson/stage.h"

namespace ff::delaunay {
template <class R> LawsonOps<R> lawson_cuda_ops();
}
