// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "plugins/abp/integrate/stage.h"

namespace ff::abp {
template <class R> IntegrateLoops<R> cuda_loops();
}
