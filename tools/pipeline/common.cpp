#include "tools/pipeline/common.h"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "core/run/builtin_stages.h"
#include "core/run/plugin_loader.h"

namespace ff::cli {

std::unique_ptr<Registry> make_registry(const std::vector<std::string>& plugins,
                                        const std::function<std::string(std::size_t)>& where) {
  auto r = std::make_unique<Registry>();
  register_builtin_stages(*r);
  const auto path = plugin_search_path();
  std::vector<std::string> files = find_stage_libraries(path);
  for (auto& f : find_plugins(plugins, path, where)) files.push_back(f);
  load_plugins(files, *r);
  std::vector<std::string> unlisted;
  for (auto& f : find_model_plugins(path))
    if (std::find(plugins.begin(), plugins.end(), model_plugin_name(f)) == plugins.end())
      unlisted.push_back(model_plugin_name(f));
  r->set_unlisted_plugins(std::move(unlisted));
  return r;
}

std::unique_ptr<Registry> make_full_registry() {
  auto r = std::make_unique<Registry>();
  register_builtin_stages(*r);
  const auto path = plugin_search_path();
  std::vector<std::string> files = find_stage_libraries(path);
  for (auto& f : find_model_plugins(path)) files.push_back(f);
  load_plugins(files, *r);
  return r;
}

Loaded load(const std::string& file, const std::vector<std::string>& overrides) {
  auto doc = PipelineDocument::parse(file, overrides);
  Loaded l;
  l.registry = make_registry(doc.plugins(), [&doc](std::size_t i) { return doc.plugin_location(i); });
  l.spec = doc.resolve(*l.registry);
  l.effective = doc.effective_text();
  l.overrides = doc.overrides();
  std::ifstream in(file);
  std::stringstream ss;
  ss << in.rdbuf();
  l.text = ss.str();
  return l;
}

std::string shell_word(const std::string& s) {
  if (!s.empty() && s.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_./=:,+-@%^") ==
                        std::string::npos)
    return s;
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace ff::cli
