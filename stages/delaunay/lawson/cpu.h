#pragma once
#include "stages/delaunay/lawson/stage.h"

namespace ff::delaunay {
template <class R> LawsonOps<R> lawson_cpu_ops();
}
