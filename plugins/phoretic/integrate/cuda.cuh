// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "plugins/phoretic/integrate/stage.h"

namespace ff::phoretic {
template <class R> IntegrateLoops<R> cuda_integrate_loops();
}
