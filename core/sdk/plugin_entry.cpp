// The entry point of every plugin library built with flipflow_add_plugin (compiled into each
// one; never into the core): the library's list of stages (core/stage/stage_registration.h), filled
// by its sources as it loads, handed to the registry. Each stage name is declared once and
// implemented for every backend its sources compiled.
#include <set>

#include "core/stage/plugin_api.h"
#include "core/stage/stage_registration.h"

namespace ff {

std::vector<PluginStage>& plugin_stages() {
  static std::vector<PluginStage> stages;
  return stages;
}

}  // namespace ff

namespace {
void register_plugin_stages(ff::Registry& r) {
  std::set<std::string> declared;
  for (const ff::PluginStage& s : ff::plugin_stages()) {
    if (!s.alias_of.empty()) continue;
    if (declared.insert(s.decl.name).second) r.declare(s.decl);
    r.implement(s.decl.name, s.backend, s.factory);
  }
  for (const ff::PluginStage& s : ff::plugin_stages())
    if (!s.alias_of.empty()) r.alias(s.decl.name, s.alias_of, s.decl.summary, s.fixed, s.defaults);
}
}  // namespace

FLIPFLOW_PLUGIN(register_plugin_stages)
