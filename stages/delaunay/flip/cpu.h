#pragma once
#include "stages/delaunay/flip/stage.h"

namespace ff::delaunay {
template <class R> FlipOps<R> flip_cpu_ops();
}
