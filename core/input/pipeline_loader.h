// YAML pipeline files -> PipelineSpec, with every error located (file:line:column, key, what
// was expected). Two phases, because the stages a file may name depend on the plugins it
// lists: parse() reads the file and applies --set overrides; plugins() says what to load;
// resolve() validates everything against the loaded registry.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "core/input/pipeline_spec.h"
#include "core/stage/registry.h"

namespace ff {

class PipelineDocument {
 public:
  // Reads `path`; applies overrides "key.path=value" (value parsed as YAML). Paths:
  // system.<key>, run.<key>, plugins, step.<id or index>.<param>. InputError on failure.
  static PipelineDocument parse(const std::string& path, const std::vector<std::string>& overrides = {});
  // Same from a string (tests); `name` is used as the file name in messages.
  static PipelineDocument parse_string(const std::string& yaml, const std::string& name,
                                       const std::vector<std::string>& overrides = {});
  ~PipelineDocument();
  PipelineDocument(PipelineDocument&&) noexcept;
  PipelineDocument& operator=(PipelineDocument&&) noexcept;

  // The document after --set, as YAML (what outputs record as the effective pipeline).
  std::string effective_text() const;
  // The --set arguments applied, in order.
  std::vector<std::string> overrides() const;

  // The `plugins:` list (validated as a list of strings).
  std::vector<std::string> plugins() const;
  // Where the i-th plugin is named: "FILE:line:column: plugins[i]" (or "--set ...: plugins[i]"),
  // the prefix of an error about that plugin (not found, not loadable).
  std::string plugin_location(std::size_t i) const;
  // Full validation against the registry: system, run, and every step entry's keys, types and
  // ranges, stage names, `after` ids, `every`, dimensions supported by each stage.
  PipelineSpec resolve(const Registry& registry) const;

 private:
  struct Impl;
  explicit PipelineDocument(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace ff
