// YAML pipeline files -> PipelineSpec: the document, --set overrides, parse and resolve.
// The readers live beside it: core/input/pipeline_sections.cpp (top level, system, run, plugins),
// core/input/pipeline_steps.cpp (step entries), core/input/pipeline_yaml.cpp (locating nodes, checked
// values and parameter maps) and core/input/pipeline_words.cpp (messages and scalars, no yaml).
// Only these files know yaml-cpp.
//
// Every error is an InputError "WHERE: PATH: what was expected, got what was found", where
// WHERE is "file:line:column" (1-based) or "--set key=value" for a node that an override
// produced, and PATH is the key path ("run.dt", "step[2] (delaunay.lawson).max_rounds").
#include "core/input/pipeline_loader.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <regex>
#include <sstream>

#include "core/base/error.h"
#include "core/base/text.h"
#include "core/input/pipeline_yaml.h"

namespace ff {

using namespace pipeline_detail;

std::string Location::str() const {
  if (line <= 0) return file;
  return file + ":" + std::to_string(line) + ":" + std::to_string(column);
}

// ---- the document -------------------------------------------------------------------------

struct PipelineDocument::Impl {
  std::string file;
  YAML::Node root;
  std::vector<Override> overrides;
  std::vector<std::string> applied;  // the --set arguments, in order

  Locator locator() const { return Locator(file, overrides); }
  void apply(const std::string& text);

 private:
  YAML::Node section(const std::string& name, const std::string& where);
  // The value of head.name with its element or key `inner` (in element `outer` = name[i] of a
  // list) set to `value`, in flow style: what --set head.name=... takes whole; then the closing
  // quote of the suggested --set, and a note where the file's value is not a map or list.
  std::string whole_value(const std::string& head, const std::string& name, const std::string& outer,
                          const std::string& inner, const YAML::Node& value) const;
  YAML::Node entry(const std::string& x, const std::string& param, const std::string& value, const std::string& where);
};

namespace {
[[noreturn]] void bad_override(const std::string& where, const std::string& what) {
  throw InputError(where + ": " + what);
}
}  // namespace

// system / run for an override: created (and attributed to the override) when absent.
YAML::Node PipelineDocument::Impl::section(const std::string& name, const std::string& where) {
  const YAML::Node& croot = root;  // const lookups never insert keys
  const YAML::Node existing = croot[name];  // invalid (not assignable) when absent
  if (existing.IsDefined() && !existing.IsNull()) {
    if (!existing.IsMap()) locator().fail(existing, name, "expected a map, got " + found(existing));
    return existing;
  }
  root[name] = YAML::Node(YAML::NodeType::Map);
  YAML::Node created = croot[name];
  overrides.push_back({created, where});
  return created;
}

// step.<x>.<param>=<value>: x is an index, or an entry id (as entry_ids() numbers them).
YAML::Node PipelineDocument::Impl::entry(const std::string& x, const std::string& param, const std::string& value,
                                         const std::string& where) {
  const YAML::Node& croot = root;
  const YAML::Node steps = croot["step"];
  if (!steps.IsDefined() || !steps.IsSequence()) bad_override(where, "the pipeline has no step list");
  std::size_t i = 0;
  if (is_number(x)) {
    i = std::stoul(x);
    if (i >= steps.size())
      bad_override(where, "no step[" + x + "]: the step list has " + std::to_string(steps.size()) + " entries");
  } else {
    const std::vector<std::string> ids = entry_ids(steps);
    auto it = std::find(ids.begin(), ids.end(), x);
    if (it == ids.end()) {
      // step.abp.integrate=5: the whole key is an entry, with no parameter named.
      if (one_of(x + "." + param, ids))
        bad_override(where, "'" + x + "." + param + "' is a step; set one of its parameters: step." + x + "." + param +
                                ".<param>=" + value);
      bad_override(where, "no step entry with id '" + x + "'" + suggestion(x, ids) + " (ids: " + join(ids) + ")");
    }
    i = std::size_t(it - ids.begin());
    // The first entry of a stage has the stage's name as its default id; with a second entry of
    // that stage also without an id of its own (stage#2), the bare name reads as "the stage" and
    // would silently set only the first. An entry with its own id is not called by the stage.
    const std::vector<std::string> stages = entry_stages(steps);
    std::vector<std::size_t> same;
    for (std::size_t k = 0; k < stages.size(); ++k)
      if (stages[k] == x && !has_own_id(steps[k])) same.push_back(k);
    if (same.size() > 1 && !has_own_id(steps[i])) {
      std::vector<std::string> named, by_index, by_id;
      for (std::size_t k : same) {
        named.push_back(index("step", k) + " id " + ids[k]);
        by_index.push_back("step." + std::to_string(k) + "." + param + "=" + value);
        if (ids[k] != x) by_id.push_back("step." + ids[k] + "." + param + "=" + value);
      }
      bad_override(where, "'" + x + "' is ambiguous: " + std::to_string(same.size()) + " entries have that stage (" +
                              join(named) + "); set one by index (" + join(by_index) + ")" +
                              (by_id.empty() ? "" : " or by id (" + join(by_id) + ")"));
    }
  }
  YAML::Node e = steps[i];
  if (!e.IsMap()) locator().fail(e, index("step", i), "expected a map with at least 'stage: <name>', got " + found(e));
  return e;
}

namespace {
// `node` in YAML's flow style, on one line ({from: a.h5, frame: 3}, [10, 20]).
std::string flow(const YAML::Node& node) {
  YAML::Emitter out;
  out << YAML::Flow << node;
  return out.c_str();
}
}  // namespace

std::string PipelineDocument::Impl::whole_value(const std::string& head, const std::string& name,
                                                const std::string& outer, const std::string& inner,
                                                const YAML::Node& value) const {
  YAML::Node whole = root[head] && root[head][name] ? YAML::Clone(root[head][name]) : YAML::Node(YAML::NodeType::Map);
  YAML::Node target = whole;
  const std::size_t open = outer.find('[');
  if (open != std::string::npos) {  // name[i]: an element of a list
    const std::string digits = outer.substr(open + 1, outer.find(']') - open - 1);
    if (!whole.IsSequence() || !is_number(digits) || std::stoul(digits) >= whole.size())
      return "[{" + inner + ": ...}, ...]' (the file has no element " + digits + " there)";
    target.reset(whole[std::stoul(digits)]);  // (reset: operator= would overwrite `whole` itself)
  }
  if (target.IsSequence() && is_number(inner) && std::stoul(inner) < target.size()) {
    target[std::stoul(inner)] = value;
  } else if (target.IsMap() || !target.IsDefined() || target.IsNull()) {
    target[inner] = value;
  } else {  // a scalar in the file (init: random): a map of the one key, and what the file has
    YAML::Node map(YAML::NodeType::Map);
    map[inner] = value;
    return flow(map) + "' (the file has " + head + "." + name + ": " + flow(target) +
           ", not a map; the map may need more keys)";
  }
  return flow(whole) + "'";
}

void PipelineDocument::Impl::apply(const std::string& given) {
  const std::string where = "--set " + given;
  const auto eq = given.find('=');
  // Spaces around '=' ('run.steps = 100', quoted) are the user's layout, not part of the key.
  std::string key = eq == std::string::npos ? "" : trimmed(given.substr(0, eq));
  if (key.empty()) bad_override(where, "expected KEY.PATH=VALUE, e.g. --set run.dt=0.001");
  // step[1].v0, as the messages name an entry, is step.1.v0.
  static const std::regex indexed(R"(step\[(\d+)\](\..*)?)");
  std::smatch m;
  if (std::regex_match(key, m, indexed)) key = "step." + m[1].str() + m[2].str();
  const std::string value_text = trimmed(given.substr(eq + 1));
  const std::string text = key + "=" + value_text;  // as resolve() reads it back
  YAML::Node value;
  try {
    value = YAML::Load(value_text);
  } catch (const YAML::ParserException& e) {
    bad_override(where, "the value is not valid YAML: " + e.msg);
  }
  const auto dot = key.find('.');
  const std::string head = key.substr(0, dot);
  const std::string rest = dot == std::string::npos ? "" : key.substr(dot + 1);
  const std::string forms = "system.<key>, run.<key>, plugins, step.<id or index>.<param>";
  if (head == "plugins" && rest.empty()) {
    root["plugins"] = value;
  } else if ((head == "system" || head == "run") && !rest.empty() && rest.find('.') == std::string::npos) {
    YAML::Node s = section(head, where);
    s[rest] = value;
  } else if (head == "step" && rest.rfind('.') != std::string::npos && rest.rfind('.') != 0 &&
             rest.rfind('.') + 1 < rest.size()) {
    const auto last = rest.rfind('.');  // ids contain dots; parameter names do not
    YAML::Node e = entry(rest.substr(0, last), rest.substr(last + 1), value_text, where);
    e[rest.substr(last + 1)] = value;
  } else if ((head == "system" || head == "run") && rest.find('.') != std::string::npos) {
    // A key inside a map or list value (run.checkpoint.every, system.init.frame,
    // system.types[0].fraction, system.box.0): that value is set whole. The message writes it out
    // from the file's own, with this change made, so that it can be pasted.
    const std::string outer = rest.substr(0, rest.find('.')), inner = rest.substr(rest.find('.') + 1);
    const std::string name = outer.substr(0, outer.find('['));
    if (inner.find('.') != std::string::npos)  // deeper than one level: say how, without writing it out
      bad_override(where, "expected one of " + forms + "; a value inside " + head + "." + name + " is set by giving " +
                              head + "." + name + " whole (--set '" + head + "." + name + "=...')");
    bad_override(where, "a value inside " + head + "." + name + " is set by giving " + head + "." + name +
                            " whole: --set '" + head + "." + name + "=" +
                            whole_value(head, name, outer, inner, value));
  } else if (one_of(head, kTopKeys)) {
    bad_override(where, "expected one of " + forms);
  } else {
    bad_override(where, "unknown section '" + head + "'" + suggestion(head, kTopKeys) + " (expected one of " +
                            forms + ")");
  }
  overrides.push_back({value, where});
  applied.push_back(text);
}

namespace {

// " (line 4: 'N:4096' has no space after ':' — write 'N: 4096')" for a block-map line at or just
// before `line` (0-based) whose key and value are joined: yaml-cpp reads the pair as one word
// and reports "illegal map value" on a later line. "" when there is none.
std::string joined_key_near(const std::vector<std::string>& lines, int line) {
  for (int i = std::min(line, int(lines.size()) - 1); i >= 0 && i >= line - 2; --i) {
    std::string text = lines[std::size_t(i)];
    if (const auto hash = text.find(" #"); hash != std::string::npos) text.erase(hash);
    const auto first = text.find_first_not_of(' ');
    if (first == std::string::npos) continue;
    text.erase(0, text.rfind("- ", first) == first ? text.find_first_not_of(' ', first + 2) : first);
    text.erase(text.find_last_not_of(" \r") + 1);
    if (auto spaced = with_space_after_colon(text))
      return " (line " + std::to_string(i + 1) + ": '" + text + "' has no space after ':' — write '" + *spaced + "')";
  }
  return "";
}

}  // namespace

PipelineDocument::PipelineDocument(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
PipelineDocument::~PipelineDocument() = default;
PipelineDocument::PipelineDocument(PipelineDocument&&) noexcept = default;
PipelineDocument& PipelineDocument::operator=(PipelineDocument&&) noexcept = default;

PipelineDocument PipelineDocument::parse(const std::string& path, const std::vector<std::string>& overrides) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw InputError("cannot read pipeline file '" + path + "': " + std::strerror(errno));
  std::string text;
  char buf[65536];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  const int err = std::ferror(f) ? errno : 0;  // e.g. EISDIR: fopen succeeds on a directory
  std::fclose(f);
  if (err) throw InputError("cannot read pipeline file '" + path + "': " + std::strerror(err));
  return parse_string(text, path, overrides);
}

PipelineDocument PipelineDocument::parse_string(const std::string& yaml, const std::string& name,
                                                const std::vector<std::string>& overrides) {
  auto impl = std::make_unique<Impl>();
  impl->file = name;
  try {
    impl->root = YAML::Load(yaml);
  } catch (const YAML::ParserException& e) {
    // A tab in an indentation is the usual cause of yaml-cpp's less telling messages.
    bool tab = false;
    std::vector<std::string> lines;
    std::istringstream in(yaml);
    for (std::string line; std::getline(in, line);) {
      const std::size_t first = line.find_first_not_of(' ');
      tab = tab || (first != std::string::npos && line[first] == '\t');
      lines.push_back(line);
    }
    fail(Location{name, e.mark.line + 1, e.mark.column + 1}, "",
         "invalid YAML: " + e.msg + (tab ? " (the file indents with a tab: YAML allows only spaces)" : "") +
             joined_key_near(lines, e.mark.line));
  }
  // The root must be a map before overrides can write into it; an empty file becomes one.
  if (impl->root.IsDefined() && !impl->root.IsNull() && !impl->root.IsMap())
    impl->locator().fail(impl->root, "", "expected a map with keys " + join(kTopKeys) + ", got " + found(impl->root));
  for (auto& o : overrides) impl->apply(o);
  top_level(impl->root, impl->locator());
  return PipelineDocument(std::move(impl));
}

std::string PipelineDocument::effective_text() const {
  YAML::Emitter out;
  out << impl_->root;
  return std::string(out.c_str()) + "\n";
}

std::vector<std::string> PipelineDocument::overrides() const {
  return impl_->applied;
}

std::vector<std::string> PipelineDocument::plugins() const {
  const Locator loc = impl_->locator();
  return read_plugins(find(top_level(impl_->root, loc), "plugins"), loc);
}

std::string PipelineDocument::plugin_location(std::size_t i) const {
  const Locator loc = impl_->locator();
  const Item* item = find(top_level(impl_->root, loc), "plugins");
  if (!item) return impl_->file + ": plugins[" + std::to_string(i) + "]";
  const bool in_list = item->value.IsSequence() && i < item->value.size();
  const Location at = in_list ? loc.at(item->value[i]) : loc.at(*item);
  return at.str() + ": " + index("plugins", i);
}

PipelineSpec PipelineDocument::resolve(const Registry& registry) const {
  const Locator loc = impl_->locator();
  const std::vector<Item> top = top_level(impl_->root, loc);
  PipelineSpec spec;
  spec.file = impl_->file;
  // Each section is read even when one before it is wrong, and its errors reported with theirs.
  InputErrorList errors;
  const bool system_read = errors.attempt([&] { spec.system = read_system(find(top, "system")->value, loc); });
  errors.attempt([&] { spec.run = read_run(find(top, "run")->value, loc); });
  errors.attempt([&] { spec.plugins = read_plugins(find(top, "plugins"), loc); });
  // (0: the dimensions are not known, and the stages' are not checked against them)
  errors.attempt([&] { spec.step = read_steps(find(top, "step")->value, system_read ? spec.system.dimensions : 0, registry, loc); });
  errors.raise();
  for (const std::string& text : impl_->applied) {  // (apply() checked their form)
    if (text.rfind("system.", 0) == 0 || text.rfind("system=", 0) == 0) spec.system.set_by.push_back(text);
    if (text.rfind("step.", 0) != 0) continue;
    const std::string key = text.substr(5, text.find('=') - 5);
    const std::string entry = key.substr(0, key.rfind('.'));
    for (std::size_t i = 0; i < spec.step.size(); ++i)
      if (entry == spec.step[i].id || entry == std::to_string(i)) spec.step[i].set_by.push_back(text);
  }
  return spec;
}

}  // namespace ff
