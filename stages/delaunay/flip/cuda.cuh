// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "stages/delaunay/flip/stage.h"

namespace ff::delaunay {
template <class R> FlipOps<R> flip_cuda_ops();
}
