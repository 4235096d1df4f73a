#include "core/run/plugin_loader.h"

#include <algorithm>
#include <boost/dll/runtime_symbol_info.hpp>
#include <boost/dll/shared_library.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>

#include "core/base/error.h"
#include "core/base/suggestion.h"
#include "core/stage/plugin_api.h"

namespace fs = std::filesystem;

namespace ff {

namespace {
const char* kStagePrefix = "libflipflow_stage_";
const char* kPluginPrefix = "libflipflow_plugin_";

// Libraries are kept open until exit (see header).
std::vector<boost::dll::shared_library>& loaded_libraries() {
  static std::vector<boost::dll::shared_library> libs;
  return libs;
}

std::vector<std::string> find_with_prefix(const std::vector<std::string>& path, const std::string& prefix) {
  std::vector<std::string> out;
  std::set<std::string> seen;
  for (auto& dir : path) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<fs::path> here;
    for (auto& e : fs::directory_iterator(dir, ec)) {
      const std::string fn = e.path().filename().string();
      if (fn.rfind(prefix, 0) == 0 && e.path().extension() == ".so") here.push_back(e.path());
    }
    std::sort(here.begin(), here.end());
    for (auto& p : here)
      if (seen.insert(p.filename().string()).second) out.push_back(p.string());
  }
  return out;
}

// The plugins' hot CPU loops are built for x86-64-v3 (FLIPFLOW_X86_64_V3, CMakeLists.txt): on an
// older CPU they would stop at the first AVX2 instruction with SIGILL; say why instead.
void require_cpu_features() {
#if defined(FLIPFLOW_X86_64_V3)
  __builtin_cpu_init();
  const char* missing = !__builtin_cpu_supports("avx2")   ? "avx2"
                        : !__builtin_cpu_supports("fma")  ? "fma"
                        : !__builtin_cpu_supports("bmi2") ? "bmi2"
                                                          : nullptr;
  if (missing)
    throw RunError(std::string("this CPU lacks ") + missing +
                   ": this flipflow build's CPU loops need an x86-64-v3 CPU (AVX2, FMA, BMI2). Rebuild with "
                   "cmake -DFLIPFLOW_X86_64_V3=OFF");
#endif
}
}  // namespace

std::vector<std::string> plugin_search_path() {
  std::vector<std::string> path;
  if (const char* env = std::getenv("FLIPFLOW_PLUGIN_PATH")) {
    std::string s = env;
    std::size_t start = 0;
    while (start <= s.size()) {
      std::size_t end = s.find(':', start);
      if (end == std::string::npos) end = s.size();
      if (end > start) path.push_back(s.substr(start, end - start));
      start = end + 1;
    }
  }
  const fs::path exe_dir = boost::dll::program_location().parent_path().string();
  path.push_back((exe_dir / ".." / "plugins").lexically_normal().string());  // a build tree
  // An installed tree (cmake --install, cmake/install.cmake): <prefix>/bin/pipeline and
  // <prefix>/lib/flipflow/plugins.
  path.push_back((exe_dir / ".." / "lib" / "flipflow" / "plugins").lexically_normal().string());
  return path;
}

std::string find_plugin(const std::string& name, const std::vector<std::string>& path) {
  if (name.find('/') != std::string::npos) {
    if (!fs::exists(name)) throw InputError("plugin library '" + name + "' does not exist");
    return name;
  }
  for (auto& dir : path) {
    fs::path p = fs::path(dir) / (kPluginPrefix + name + ".so");
    if (fs::exists(p)) return p.string();
  }
  // The standard stage libraries (and core.noop) need no listing: naming one is a mistake to
  // undo, not a library to find.
  if (name == "core")
    throw InputError("plugin 'core' not found: the core.* stages are built in; remove 'core' from `plugins:`");
  for (auto& file : find_stage_libraries(path))
    if (fs::path(file).stem().string() == kStagePrefix + name)
      throw InputError("plugin '" + name + "' not found: the " + name + ".* stages are built in (" + file +
                       ", always loaded); remove '" + name + "' from `plugins:`");
  std::vector<std::string> known;
  for (auto& file : find_model_plugins(path)) known.push_back(model_plugin_name(file));
  std::string dirs;
  for (auto& d : path) dirs += "\n  " + d;
  const std::string meant = suggestion(name, known);
  throw InputError("plugin '" + name + "' not found" + (meant.empty() ? ": no " : meant + " No ") + kPluginPrefix + name +
                   ".so in the plugin search path (FLIPFLOW_PLUGIN_PATH, then the build's or the install's "
                   "plugin folder):" + dirs);
}

std::vector<std::string> find_plugins(const std::vector<std::string>& names, const std::vector<std::string>& path,
                                      const std::function<std::string(std::size_t)>& where) {
  std::vector<std::string> files;
  for (std::size_t i = 0; i < names.size(); ++i) {
    try {
      const std::string file = find_plugin(names[i], path);
      // Checked here, where the list's entry is known: a file that is no shared library (Boost's
      // load error would not say where it was listed), a library listed twice.
      char magic[4] = {};
      std::ifstream(file, std::ios::binary).read(magic, 4);
      if (!(magic[0] == 0x7f && magic[1] == 'E' && magic[2] == 'L' && magic[3] == 'F'))
        throw InputError("plugin '" + names[i] + "' (" + file + ") is not a shared library (no ELF header)");
      for (std::size_t j = 0; j < files.size(); ++j) {
        std::error_code ec;
        if (fs::equivalent(files[j], file, ec))
          throw InputError("plugin '" + names[i] + "' is listed twice (also as plugins[" + std::to_string(j) + "])");
      }
      files.push_back(file);
    } catch (const InputError& e) {
      const std::string at = where ? where(i) : std::string();
      if (at.empty()) throw;
      throw InputError(at + ": " + e.what());
    }
  }
  return files;
}

std::vector<std::string> find_stage_libraries(const std::vector<std::string>& path) {
  return find_with_prefix(path, kStagePrefix);
}

std::vector<std::string> find_model_plugins(const std::vector<std::string>& path) {
  return find_with_prefix(path, kPluginPrefix);
}

std::string model_plugin_name(const std::string& file) {
  std::string n = fs::path(file).stem().string();
  if (n.rfind(kPluginPrefix, 0) == 0) n.erase(0, std::string(kPluginPrefix).size());
  return n;
}

void load_plugins(const std::vector<std::string>& files, Registry& registry) {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  if (!files.empty()) require_cpu_features();
  struct Opened {
    std::string file;
    boost::dll::shared_library lib;
  };
  std::vector<Opened> opened;
  // 1. open and check everything
  for (auto& file : files) {
    boost::dll::shared_library lib;
    try {
      lib.load(file, boost::dll::load_mode::rtld_now | boost::dll::load_mode::rtld_local);
    } catch (const std::exception& e) {
      throw InputError("cannot load plugin '" + file + "': " + e.what());
    }
    if (!lib.has("flipflow_abi_version") || !lib.has("flipflow_register"))
      throw InputError("'" + file + "' is not a flipflow plugin: it does not export " +
                       (lib.has("flipflow_abi_version") ? "flipflow_register" : "flipflow_abi_version") +
                       " (use FLIPFLOW_PLUGIN(...) from core/stage/plugin_api.h)");
    const int version = lib.get_alias<AbiVersionFunction>("flipflow_abi_version")();
    if (version != FF_ABI_VERSION)
      throw InputError("plugin '" + file + "' was built for flipflow ABI version " + std::to_string(version) +
                       ", this flipflow has version " + std::to_string(FF_ABI_VERSION) + ": rebuild the plugin");
    opened.push_back({file, std::move(lib)});
  }
  // 2. register
  for (auto& o : opened) {
    registry.set_current_plugin(fs::path(o.file).filename().string());
    const std::size_t before = registry.declared_count();
    o.lib.get_alias<RegisterFunction>("flipflow_register")(registry);
    // A plugin whose stage.h files were all left out of its build (cmake/flipflow_plugin.cmake)
    // would otherwise load in silence, and its stages be reported unknown as if it were unlisted.
    if (registry.declared_count() == before)
      throw InputError("plugin '" + o.file + "' registers no stages: none of its stage.h files ends in " +
                       "FLIPFLOW_STAGE(...) or FLIPFLOW_HOST_STAGE(...) (docs/writing-a-model.md)");
    loaded_libraries().push_back(o.lib);
  }
  registry.resolve_aliases();
  registry.set_current_plugin("(built in)");
}

}  // namespace ff
