#pragma once
#include "plugins/brownian/integrate/stage.h"

namespace ff::brownian {
template <class R> IntegrateLoops<R> cpu_loops();
}
