// Where the core's test plugins are (<dir of the test binary>/../test-plugins), and a registry
// helper for tests.
#pragma once
#include <boost/dll/runtime_symbol_info.hpp>
#include <string>

#include "core/run/builtin_stages.h"
#include "core/run/plugin_loader.h"
#include "core/stage/registry.h"

namespace ff::test {

inline std::string test_plugin(const std::string& name) {
  const auto dir = boost::dll::program_location().parent_path().parent_path() / "test-plugins";
  return (dir / ("libflipflow_plugin_" + name + ".so")).string();
}

// Built-ins + standard stage libraries + the named model plugins + the named test plugins.
inline std::unique_ptr<Registry> registry_with(const std::vector<std::string>& plugins,
                                               const std::vector<std::string>& test_plugins = {}) {
  auto r = std::make_unique<Registry>();
  register_builtin_stages(*r);
  const auto path = plugin_search_path();
  auto files = find_stage_libraries(path);
  for (auto& p : plugins) files.push_back(find_plugin(p, path));
  for (auto& p : test_plugins) files.push_back(test_plugin(p));
  load_plugins(files, *r);
  return r;
}

}  // namespace ff::test
