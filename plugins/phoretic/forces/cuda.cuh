// Launcher declarations for the CUDA build (defined in cuda.cu).
#pragma once
#include "plugins/phoretic/forces/stage.h"

namespace ff::phoretic {
template <class R> ForcesLoops<R> cuda_forces_loops();
}
