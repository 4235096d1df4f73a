#include "core/registry.h"

#include "core/error.h"

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

const StageEntryInfo& Registry::get(const std::string& name) const {
  auto it = stages_.find(name);
  if (it == stages_.end()) {
    std::string known;
    for (auto& kv : stages_) known += (known.empty() ? "" : ", ") + kv.first;
    throw InputError("unknown stage '" + name + "' (loaded stages: " + known + ")");
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
