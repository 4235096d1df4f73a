// The observe stages: output and monitoring, host-side, run after each accepted step.
#include "core/plugin_api.h"

namespace ff::observe {
void register_h5md(Registry& r);
void register_progress(Registry& r);
void register_msd(Registry& r);
void register_gr(Registry& r);
}  // namespace ff::observe

static void register_observe(ff::Registry& r) {
  ff::observe::register_h5md(r);
  ff::observe::register_progress(r);
  ff::observe::register_msd(r);
  ff::observe::register_gr(r);
}

FLIPFLOW_PLUGIN(register_observe)
