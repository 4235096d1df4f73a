// The neighbors stage library: cell list + Verlet list with Tran's dynamic rebuild test.
#include "core/plugin_api.h"

namespace ff::neighbors {
void register_verlet(Registry& r);
}

static void register_neighbors(ff::Registry& r) { ff::neighbors::register_verlet(r); }

FLIPFLOW_PLUGIN(register_neighbors)
