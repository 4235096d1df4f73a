#pragma once
#include "plugins/phoretic/forces/stage.h"

namespace ff::phoretic {
template <class R> ForcesLoops<R> cpu_forces_loops();
}
