#pragma once
#include "stages/overlap_correct/stage.h"

namespace ff::overlap {
template <class R> Ops<R> cpu_ops();
}
