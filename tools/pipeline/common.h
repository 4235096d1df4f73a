// What every `pipeline` subcommand shares: reading a pipeline file, loading the plugins it
// needs, and the registry.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "core/input/pipeline_loader.h"
#include "core/input/pipeline_spec.h"
#include "core/stage/registry.h"

namespace ff::cli {

struct Loaded {
  std::unique_ptr<Registry> registry;
  PipelineSpec spec;
  std::string text;  // the file's text, recorded in outputs
};

// Registry with the built-in stages, every standard stage library and the listed plugins.
std::unique_ptr<Registry> make_registry(const std::vector<std::string>& plugins);
// Registry with everything found on the plugin path (for `stages` and `describe`).
std::unique_ptr<Registry> make_full_registry();
// Parse + load plugins + validate. InputError on any problem.
Loaded load(const std::string& file, const std::vector<std::string>& overrides);

}  // namespace ff::cli
