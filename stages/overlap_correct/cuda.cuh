// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "stages/overlap_correct/stage.h"

namespace ff::overlap {
template <class R> Ops<R> cuda_ops();
}
