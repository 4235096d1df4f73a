// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "plugins/brownian/integrate/stage.h"

namespace ff::brownian {
template <class R> IntegrateLoops<R> cuda_loops();
}
