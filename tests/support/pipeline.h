// A shipped pipeline file loaded for a test: its plugins (plus test plugins), the resolved spec
// with --set style overrides, observers removed (they write files; the tests drive
// Simulation::advance and read the state).
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "core/input/pipeline_loader.h"
#include "core/stage/registry.h"
#include "support/test_plugins.h"

namespace ff::test {

struct LoadedPipeline {
  std::unique_ptr<Registry> registry;
  PipelineSpec spec;
};

inline LoadedPipeline load_compute_steps(const std::string& file, const std::vector<std::string>& overrides,
                                         const std::vector<std::string>& test_plugins = {}) {
  auto doc = PipelineDocument::parse(file, overrides);
  LoadedPipeline l{registry_with(doc.plugins(), test_plugins), {}};
  l.spec = doc.resolve(*l.registry);
  std::vector<StepEntry> compute;
  for (auto& e : l.spec.step)
    if (!l.registry->get(e.stage).decl.observer) compute.push_back(e);
  l.spec.step = compute;
  return l;
}

}  // namespace ff::test
