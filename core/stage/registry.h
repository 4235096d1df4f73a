// The stage registry: names -> declaration (parameters, doc) and one factory per backend.
// Plugins fill it through their registration function (core/stage/plugin_api.h).
#pragma once
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/stage/params.h"
#include "core/stage/stage.h"

namespace ff {

using StageFactory = std::function<std::unique_ptr<Stage>(const ParamValues&, const RunInfo&)>;

struct StageDecl {
  std::string name;                // "delaunay.lawson"
  std::string summary;             // one line for `pipeline stages`
  std::vector<ParamSpec> params;
  std::vector<int> dimensions = {2, 3};
  // Observe stages write files, not state; they run after the step is accepted and are never
  // part of the rollback snapshot.
  bool observer = false;
  // Stages of which at least one must come earlier in the step (delaunay.flip repairs what
  // delaunay.detect_inversion marks): a pipeline without one is refused at validate, naming them.
  // Unit tests that make a stage alone are not bound by it.
  std::vector<std::string> needs_before = {};
};

struct StageEntryInfo {
  StageDecl decl;
  std::string plugin;  // library that registered it
  std::map<Backend, StageFactory> factories;
};

class Registry {
 public:
  // Called by plugins. Declaring a name twice, or implementing a backend twice, throws
  // (naming both plugins). `plugin` is filled in by the loader.
  void declare(StageDecl decl);
  void implement(const std::string& name, Backend backend, StageFactory factory);
  // `name` runs the stage `target` with the parameters in `fixed` set (an older name kept for a
  // configuration of a newer stage) and the defaults in `defaults` changed; its other
  // parameters are the target's. Takes effect at resolve_aliases(), so the target may come
  // from a library loaded later.
  void alias(const std::string& name, const std::string& target, const std::string& summary,
             const ParamValues& fixed, const ParamValues& defaults = {});
  // Registers the aliases declared so far (the plugin loader calls it after registering every
  // library). InputError naming the plugin if a target is missing.
  void resolve_aliases();

  bool has(const std::string& name) const { return stages_.count(name) != 0; }
  const StageEntryInfo& get(const std::string& name) const;  // InputError if unknown
  std::vector<std::string> names() const;
  // Stages and aliases registered so far (the loader's check that a plugin registered any).
  std::size_t declared_count() const { return stages_.size() + pending_aliases_.size(); }
  std::unique_ptr<Stage> create(const std::string& name, Backend backend, const ParamValues& params,
                                const RunInfo& info) const;

  // Model plugins on the search path that the pipeline does not list (names as `plugins:` takes
  // them), so an unknown stage's message can say which one to list.
  void set_unlisted_plugins(std::vector<std::string> names) { unlisted_plugins_ = std::move(names); }
  const std::vector<std::string>& unlisted_plugins() const { return unlisted_plugins_; }

  // The loader sets this while a plugin's registration function runs.
  void set_current_plugin(std::string plugin) { current_plugin_ = std::move(plugin); }

 private:
  struct PendingAlias {
    std::string name, target, summary, plugin;
    ParamValues fixed, defaults;
  };
  void add_alias(const PendingAlias& a);
  std::map<std::string, StageEntryInfo> stages_;
  std::vector<PendingAlias> pending_aliases_;
  std::string current_plugin_ = "(built in)";
  std::vector<std::string> unlisted_plugins_;
};

}  // namespace ff
