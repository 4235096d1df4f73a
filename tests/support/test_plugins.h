// Where the core's test plugins are (<dir of the test binary>/../test-plugins), and registries
// for tests.
#pragma once
#include <boost/dll/runtime_symbol_info.hpp>
#include <catch2/catch.hpp>
#include <filesystem>
#include <string>
#include <vector>

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

// Only the named standard stage libraries (libflipflow_stage_<name>.so) and model plugins, no
// built-ins: what a test of one stage loads, so that it sees no other library's stages.
inline std::unique_ptr<Registry> registry_of(const std::vector<std::string>& stage_libraries,
                                             const std::vector<std::string>& plugins = {}) {
  const auto path = plugin_search_path();
  const auto found = find_stage_libraries(path);
  std::vector<std::string> files;
  for (auto& lib : stage_libraries) {
    const std::string file = "libflipflow_stage_" + lib + ".so";
    std::size_t hits = 0;
    for (auto& f : found)
      if (std::filesystem::path(f).filename() == file) {
        files.push_back(f);
        ++hits;
      }
    INFO(file << " in the plugin path");
    REQUIRE(hits == 1);
  }
  for (auto& p : plugins) files.push_back(find_plugin(p, path));
  auto r = std::make_unique<Registry>();
  load_plugins(files, *r);
  return r;
}

}  // namespace ff::test
