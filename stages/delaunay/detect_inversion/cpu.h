#pragma once
#include "stages/delaunay/detect_inversion/stage.h"

namespace ff::delaunay {
template <class R> DetectOps<R> detect_cpu_ops();
}
