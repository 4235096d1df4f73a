// Registries for tests: the standard stages and model plugins a test loads, found on
// test_plugin_path(), and the core's test plugins (<dir of the test binary>/../test-plugins, this
// repository only). Installed with the SDK (cmake/install.cmake): a test beside a stage of a model
// built against an install includes it as here.
#pragma once
#include <algorithm>
#include <boost/dll/runtime_symbol_info.hpp>
#include <catch2/catch.hpp>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/run/builtin_stages.h"
#include "core/run/plugin_loader.h"
#include "core/stage/registry.h"

namespace ff::test {

// Where a test looks for plugins. In this repository plugin_search_path(): FLIPFLOW_PLUGIN_PATH,
// then the build tree's plugins next to the test binary. A test of a project built against an
// install (flipflow_add_plugin there defines FLIPFLOW_STAGE_TEST_PLUGIN_PATH: the folders of the
// project's plugins, then the install's plugin folder) looks in those first: its binary is not
// beside them, and it must load the plugin just built and the standard stages of the install it
// was built against, whatever FLIPFLOW_PLUGIN_PATH says and wherever it is run from.
inline std::vector<std::string> test_plugin_path() {
  std::vector<std::string> path;
#ifdef FLIPFLOW_STAGE_TEST_PLUGIN_PATH
  const std::string dirs = FLIPFLOW_STAGE_TEST_PLUGIN_PATH;  // colon-separated, as FLIPFLOW_PLUGIN_PATH
  for (std::size_t begin = 0, end; begin <= dirs.size(); begin = end + 1) {
    end = std::min(dirs.find(':', begin), dirs.size());
    if (end > begin) path.push_back(dirs.substr(begin, end - begin));
  }
#endif
  for (auto& dir : plugin_search_path()) path.push_back(dir);
  return path;
}

inline std::string test_plugin(const std::string& name) {
  const auto dir = boost::dll::program_location().parent_path().parent_path() / "test-plugins";
  return (dir / ("libflipflow_plugin_" + name + ".so")).string();
}

// Built-ins + standard stage libraries + the named model plugins + the named test plugins.
inline std::unique_ptr<Registry> registry_with(const std::vector<std::string>& plugins,
                                               const std::vector<std::string>& test_plugins = {}) {
  auto r = std::make_unique<Registry>();
  register_builtin_stages(*r);
  const auto path = test_plugin_path();
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
  const auto path = test_plugin_path();
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
