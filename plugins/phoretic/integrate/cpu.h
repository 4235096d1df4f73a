#pragma once
#include "plugins/phoretic/integrate/stage.h"

namespace ff::phoretic {
template <class R> IntegrateLoops<R> cpu_integrate_loops();
}
