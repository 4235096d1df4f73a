// Exports the flipflow entry points but registers nothing, as a plugin does whose stage.h files
// were all left out of its build: loading it must fail, naming the library.
#include "core/stage/plugin_api.h"
namespace {
void register_nothing(ff::Registry&) {}
}  // namespace
FLIPFLOW_PLUGIN(register_nothing)
