// What every `pipeline` subcommand shares: reading a pipeline file, loading the plugins it
// needs, and the registry.
#pragma once
#include <cstddef>
#include <functional>
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
  std::string effective;               // the document after --set, as YAML
  std::vector<std::string> overrides;  // the --set arguments applied
};

// Registry with the built-in stages, every standard stage library and the listed plugins.
// A plugin that is not found is reported at where(i) ("FILE:line:column: plugins[i]").
std::unique_ptr<Registry> make_registry(const std::vector<std::string>& plugins,
                                        const std::function<std::string(std::size_t)>& where = {});
// Registry with everything found on the plugin path (for `stages` and `describe`).
std::unique_ptr<Registry> make_full_registry();
// `s` as one word of a POSIX shell's command line (quoted where it must be), for the commands
// messages print for pasting.
std::string shell_word(const std::string& s);
// Parse + load plugins + validate. InputError on any problem.
Loaded load(const std::string& file, const std::vector<std::string>& overrides);

}  // namespace ff::cli
