// A plugin built for another ABI version: the loader must refuse it.
#define FF_PLUGIN_ABI_VERSION 999
#include "core/stage/plugin_api.h"
static void register_nothing(ff::Registry&) {}
FLIPFLOW_PLUGIN(register_nothing)
