// Finds and loads plugin libraries with Boost.DLL. Search path: the directories in
// FLIPFLOW_PLUGIN_PATH (colon-separated) first, then ../plugins (a build tree) and
// ../lib/flipflow/plugins (an installed tree) next to the executable.
//
// Standard stage libraries are named libflipflow_stage_<name>.so and are always loaded for a
// run; model plugins are libflipflow_plugin_<name>.so and are loaded when a pipeline names them
// under `plugins:` (a name containing '/' is taken as a path to the library itself).
// All libraries are opened and version-checked first, then registered (so a broken plugin
// never leaves a half-filled registry). Loaded libraries stay loaded for the life of the
// process: stages created from them may live until exit.
#pragma once
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "core/stage/registry.h"

namespace ff {

std::vector<std::string> plugin_search_path();

// Resolve a plugin name to a library file; InputError listing the searched directories if absent.
std::string find_plugin(const std::string& name, const std::vector<std::string>& path);

// find_plugin for each name; a name not found is reported at where(i) (the pipeline file's
// "FILE:line:column: plugins[i]", PipelineDocument::plugin_location), where the user fixes it.
std::vector<std::string> find_plugins(const std::vector<std::string>& names, const std::vector<std::string>& path,
                                      const std::function<std::string(std::size_t)>& where);

// Every standard stage library (libflipflow_stage_*.so) found on the path, first hit per name.
std::vector<std::string> find_stage_libraries(const std::vector<std::string>& path);
// Every model plugin found on the path (for `pipeline stages`).
std::vector<std::string> find_model_plugins(const std::vector<std::string>& path);
// The name a pipeline's `plugins:` gives the model plugin in `file` (libflipflow_plugin_NAME.so).
std::string model_plugin_name(const std::string& file);

// Open all files, check each exports flipflow_abi_version == FF_ABI_VERSION and
// flipflow_register, then call each registration function in order.
void load_plugins(const std::vector<std::string>& files, Registry& registry);

}  // namespace ff
