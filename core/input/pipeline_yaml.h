// Internal to the pipeline loader: what its yaml-reading .cpp files share (locating nodes,
// map entries, checked values and parameter maps) and the readers each provides. Included
// only by core/input/pipeline_loader.cpp, core/input/pipeline_yaml.cpp, core/input/pipeline_sections.cpp and
// core/input/pipeline_steps.cpp, the only files that know yaml-cpp; never include it elsewhere.
//
// Every error is an InputError "WHERE: PATH: what was expected, got what was found", where
// WHERE is "file:line:column" (1-based) or "--set key=value" for a node that an override
// produced, and PATH is the key path ("run.dt", "step[2] (delaunay.lawson).max_rounds").
#pragma once
#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/stage/params.h"
#include "core/input/pipeline_spec.h"
#include "core/input/pipeline_words.h"
#include "core/stage/registry.h"

namespace ff::pipeline_detail {

inline const std::vector<std::string> kTopKeys = {"system", "run", "plugins", "step"};

// "'value'", "a list", "a map" or "nothing": what a message says was found.
std::string found(const YAML::Node& n);

// ---- locating nodes -----------------------------------------------------------------------

// A subtree that came from --set, with the text that produced it.
struct Override {
  YAML::Node node;
  std::string text;  // "--set run.dt=abc"
};

struct Item {
  std::string key;
  YAML::Node key_node, value;
};

class Locator {
 public:
  Locator(const std::string& file, const std::vector<Override>& overrides) : file_(file), overrides_(overrides) {}

  Location at(const YAML::Node& n) const;
  Location at(const Item& item) const;
  [[noreturn]] void fail(const YAML::Node& n, const std::string& path, const std::string& what) const {
    pipeline_detail::fail(at(n), path, what);
  }

 private:
  const std::string& file_;
  const std::vector<Override>& overrides_;
};

// The entries of a map in file order; rejects non-maps, non-scalar keys and duplicate keys.
std::vector<Item> items_of(const YAML::Node& map, const std::string& path, const std::string& expected,
                           const Locator& loc);
const Item* find(const std::vector<Item>& items, const std::string& key);  // nullptr if absent

// ---- values and maps of parameters --------------------------------------------------------

// One value checked against its spec: type, range, choices.
ParamValue read_value(const ParamSpec& spec, const YAML::Node& n, const std::string& path, const Locator& loc);

// How a map of parameters is checked: its schema, the keys the caller reads itself, the
// declared keys that are optional without a default, and the words for errors.
struct Schema {
  std::vector<ParamSpec> params;
  std::vector<std::string> reserved;
  std::vector<std::string> optional;
  std::string kind = "key";  // "key" | "parameter"
  std::string known;         // listed after an unknown key
};

ParamValues read_params(const YAML::Node& map, const std::vector<Item>& items, const std::string& path,
                        const Schema& schema, const Locator& loc);
// "known keys: a, b, ..." for the names in `params`, then `extra`.
std::string known_keys(const std::vector<ParamSpec>& params, const std::vector<std::string>& extra);

// ---- sections (core/input/pipeline_sections.cpp) ------------------------------------------------

// The top-level entries, checked: known keys only, system/run/step present.
std::vector<Item> top_level(const YAML::Node& root, const Locator& loc);
SystemSpec read_system(const YAML::Node& n, const Locator& loc);
RunSpec read_run(const YAML::Node& n, const Locator& loc);
std::vector<std::string> read_plugins(const Item* item, const Locator& loc);  // item may be nullptr

// ---- step entries (core/input/pipeline_steps.cpp) -----------------------------------------------

// Ids as the user will refer to them (explicit id, else stage, stage#2 ...); lenient.
std::vector<std::string> entry_ids(const YAML::Node& steps);
// Each entry's stage name ("" where malformed), and whether it gives its own `id`; lenient too.
std::vector<std::string> entry_stages(const YAML::Node& steps);
bool has_own_id(const YAML::Node& entry);
std::vector<StepEntry> read_steps(const YAML::Node& n, int dim, const Registry& reg, const Locator& loc);

}  // namespace ff::pipeline_detail
