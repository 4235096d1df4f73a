#include "core/stage/registry.h"

#include "core/base/error.h"
#include "core/base/suggestion.h"

namespace ff {

void Registry::declare(StageDecl decl) {
  auto it = stages_.find(decl.name);
  if (it != stages_.end())
    throw InputError("stage '" + decl.name + "' is registered twice: by plugin '" + it->second.plugin +
                     "' and by plugin '" + current_plugin_ + "'");
  std::string name = decl.name;
  stages_[name] = StageEntryInfo{std::move(decl), current_plugin_, {}};
}

void Registry::implement(const std::string& name, Backend backend, StageFactory factory) {
  auto it = stages_.find(name);
  if (it == stages_.end())
    throw InputError("plugin '" + current_plugin_ + "' implements stage '" + name +
                     "' without declaring it first");
  if (it->second.factories.count(backend))
    throw InputError("stage '" + name + "' has two " + to_string(backend) + " implementations (plugin '" +
                     current_plugin_ + "')");
  it->second.factories[backend] = std::move(factory);
}

void Registry::alias(const std::string& name, const std::string& target, const std::string& summary,
                     const ParamValues& fixed, const ParamValues& defaults) {
  pending_aliases_.push_back({name, target, summary, current_plugin_, fixed, defaults});
}

void Registry::resolve_aliases() {
  const std::string current = current_plugin_;
  auto pending = std::move(pending_aliases_);
  pending_aliases_.clear();
  for (const PendingAlias& a : pending) {
    current_plugin_ = a.plugin;
    add_alias(a);
  }
  current_plugin_ = current;
}

void Registry::add_alias(const PendingAlias& a) {
  const std::string &name = a.name, &target = a.target;
  auto t = stages_.find(target);
  if (t == stages_.end())
    throw InputError("plugin '" + current_plugin_ + "' declares '" + name + "' as an alias of stage '" + target +
                     "', which no loaded plugin registers");
  StageDecl decl = t->second.decl;
  decl.name = name;
  std::string with;
  for (auto& kv : a.fixed.all()) with += (with.empty() ? "" : ", ") + kv.first + ": " + format_value(kv.second);
  decl.summary = a.summary + " (= " + target + (with.empty() ? "" : " with " + with) + ")";
  std::vector<ParamSpec> params;
  for (auto& p : decl.params) {
    if (a.fixed.has(p.name)) continue;
    params.push_back(p);
    if (a.defaults.has(p.name)) params.back().default_value = a.defaults.all().at(p.name);
  }
  decl.params = params;
  declare(std::move(decl));
  for (auto& kv : t->second.factories) {
    StageFactory make = kv.second;
    implement(name, kv.first, [make, fixed = a.fixed](const ParamValues& v, const RunInfo& info) {
      ParamValues all = v;
      for (auto& f : fixed.all()) all.set(f.first, f.second);
      return make(all, info);
    });
  }
}

const StageEntryInfo& Registry::get(const std::string& name) const {
  auto it = stages_.find(name);
  if (it == stages_.end()) {
    std::string known;
    for (auto& kv : stages_) known += (known.empty() ? "" : ", ") + kv.first;
    throw InputError("unknown stage '" + name + "'" + suggestion(name, names()) + " (loaded stages: " + known + ")");
  }
  return it->second;
}

std::vector<std::string> Registry::names() const {
  std::vector<std::string> n;
  for (auto& kv : stages_) n.push_back(kv.first);
  return n;
}

std::unique_ptr<Stage> Registry::create(const std::string& name, Backend backend, const ParamValues& params,
                                        const RunInfo& info) const {
  const auto& e = get(name);
  auto it = e.factories.find(backend);
  if (it == e.factories.end())
    throw InputError("stage '" + name + "' (plugin '" + e.plugin + "') has no " + to_string(backend) +
                     " implementation; run with --device " +
                     (backend == Backend::cuda ? "cpu" : "cuda") + " or remove the stage");
  return it->second(params, info);
}

}  // namespace ff
