// Stages the core provides itself (no plugin): `core.noop`, a stage that does nothing, used to
// measure framework overhead (`pipelines/bench-noop.yaml`) and in scheduler tests.
#pragma once
#include "core/stage/registry.h"

namespace ff {
void register_builtin_stages(Registry& registry);
}
