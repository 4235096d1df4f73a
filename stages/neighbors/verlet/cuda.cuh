// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "stages/neighbors/verlet/stage.h"

namespace ff::neighbors {
template <class R> VerletLoops<R> cuda_loops();
}
