// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "stages/delaunay/detect_inversion/stage.h"

namespace ff::delaunay {
template <class R> DetectOps<R> detect_cuda_ops();
}
