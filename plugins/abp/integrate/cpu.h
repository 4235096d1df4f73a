#pragma once
#include "plugins/abp/integrate/stage.h"

namespace ff::abp {
template <class R> IntegrateLoops<R> cpu_loops();
}
