#pragma once
#include "stages/neighbors/verlet/stage.h"

namespace ff::neighbors {
template <class R> VerletLoops<R> cpu_loops();
}
