// The pipeline file's `step` list: entry heads (stage, dimensions, id), unique ids, `after`
// references, `every` or `at` (the schedule), and each entry's stage parameters checked against its declaration.
#include <algorithm>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "core/input/pipeline_yaml.h"

namespace ff::pipeline_detail {

namespace {

const std::vector<std::string> kEntryKeys = {"stage", "id", "after", "every", "at"};

// A const lookup of a missing key gives an invalid node, on which Type() throws.
bool scalar_in(const YAML::Node& map, const char* key) {
  if (!map.IsMap()) return false;
  const YAML::Node v = map[key];
  return v.IsDefined() && v.IsScalar();
}

}  // namespace

// Ids as the user will refer to them: an explicit `id`, else the stage name, numbered name#2,
// name#3 ... for repeats. Lenient ("" where the entry is malformed) so that --set can find
// entries before validation; resolve() validates first, then uses the same numbering.
std::vector<std::string> entry_ids(const YAML::Node& steps) {
  std::vector<std::string> ids;
  std::map<std::string, int> seen;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const YAML::Node e = steps[i];
    std::string id;
    if (scalar_in(e, "id")) id = e["id"].Scalar();
    else if (scalar_in(e, "stage")) {
      const std::string stage = e["stage"].Scalar();
      const int k = ++seen[stage];
      id = k == 1 ? stage : stage + "#" + std::to_string(k);
    }
    ids.push_back(id);
  }
  return ids;
}

std::vector<std::string> entry_stages(const YAML::Node& steps) {
  std::vector<std::string> stages;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const YAML::Node e = steps[i];
    stages.push_back(scalar_in(e, "stage") ? e["stage"].Scalar() : "");
  }
  return stages;
}

bool has_own_id(const YAML::Node& entry) { return scalar_in(entry, "id"); }

namespace {

// What the first pass learns about an entry: enough to name it and to resolve `after`.
struct Head {
  YAML::Node node;
  std::vector<Item> items;
  std::string stage, label;  // label: "step[2] (delaunay.lawson)"
  bool read = false;         // false: its head was refused (label "step[2]"), and nothing else is read
};

Head read_head(const YAML::Node& e, std::size_t i, int dim, const Registry& reg, const Locator& loc) {
  const std::string at = index("step", i);
  Head h{e, items_of(e, at, "a map with at least 'stage: <name>'", loc), {}, at};
  const Item* stage = find(h.items, "stage");
  if (!stage) {
    // A misspelt 'stage' would otherwise be reported as missing, the word itself unmentioned.
    for (const Item& item : h.items)
      if (!one_of(item.key, kEntryKeys) && !suggestion(item.key, {"stage"}).empty())
        fail(loc.at(item), at + "." + item.key, "unknown key '" + item.key + "'; did you mean 'stage'?");
    loc.fail(e, at, "missing required key 'stage' (the name of a loaded stage)");
  }
  h.stage = std::get<std::string>(read_value(ParamSpec::string("stage", std::nullopt, ""), stage->value,
                                             at + ".stage", loc));
  if (!reg.has(h.stage)) {
    // A model plugin's stages are named after it (harmonic.forces in plugin harmonic).
    const std::string prefix = h.stage.substr(0, h.stage.find('.'));
    const auto& unlisted = reg.unlisted_plugins();
    const bool in_unlisted = std::find(unlisted.begin(), unlisted.end(), prefix) != unlisted.end();
    const std::string s = in_unlisted ? std::string() : suggestion(h.stage, reg.names());
    loc.fail(stage->value, at + ".stage",
             "unknown stage '" + h.stage + "'" + s + " (loaded stages: " + join(reg.names()) + ")" +
                 (in_unlisted ? "; plugin '" + prefix + "' is on the plugin path but not in this pipeline's "
                                "`plugins:` list: add '" + prefix + "' to it"
                  : s.empty() ? "; is its plugin listed under 'plugins'?" : ""));
  }
  const StageDecl& decl = reg.get(h.stage).decl;
  if (dim != 0 && !std::count(decl.dimensions.begin(), decl.dimensions.end(), dim)) {
    std::vector<std::string> dims;
    for (int d : decl.dimensions) dims.push_back(std::to_string(d));
    // The triangulation is 2D: a 2D pipeline made 3D (--set system.dimensions=3) needs the
    // Verlet list's exclusion instead, which the message names rather than leave it to be found.
    const bool planar = h.stage.rfind("delaunay.", 0) == 0 || h.stage == "overlap_correct" ||
                        h.stage.rfind("voronoi.", 0) == 0 || h.stage == "neighbors.delaunay";
    loc.fail(stage->value, at + ".stage",
             "stage '" + h.stage + "' supports dimensions " + join(dims) + " only, but system.dimensions is " +
                 std::to_string(dim) +
                 (planar && dim == 3 ? " (the Delaunay and Voronoi stages are 2D; hard-core exclusion in 3D is "
                                       "neighbors.verlet + overlap_correct.verlet, as in pipelines/hard-spheres.yaml)"
                                     : ""));
  }
  h.label = at + " (" + h.stage + ")";
  h.read = true;
  if (const Item* id = find(h.items, "id")) {
    const std::string v = std::get<std::string>(
        read_value(ParamSpec::string("id", std::nullopt, ""), id->value, h.label + ".id", loc));
    if (v.empty() || is_number(v))
      loc.fail(id->value, h.label + ".id", "expected a name that is not a number, got " + found(id->value));
  }
  return h;
}

// Ids must be unique; a default id that collides is reported at the entry's stage.
void check_unique(const std::vector<Head>& heads, const std::vector<std::string>& ids, const Locator& loc) {
  for (std::size_t i = 0; i < ids.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (heads[i].read && heads[j].read && ids[i] == ids[j]) {
        const Item* id = find(heads[i].items, "id");
        const Item* at = id ? id : find(heads[i].items, "stage");
        fail(loc.at(at->value), heads[i].label + "." + at->key,
             "duplicate id '" + ids[i] + "' (already the id of " + heads[j].label + " at " +
                 loc.at(heads[j].node).str() + "); give each entry a unique 'id'");
      }
}

// `after`: one id or a list of ids, each naming an entry declared earlier (so the step graph
// is acyclic by construction).
std::vector<std::string> read_after(const Item& item, std::size_t i, const std::vector<Head>& heads,
                                    const std::vector<std::string>& ids, const Locator& loc) {
  const std::string path = heads[i].label + ".after";
  std::vector<std::pair<std::string, YAML::Node>> refs;
  if (item.value.IsScalar()) refs.emplace_back(item.value.Scalar(), item.value);
  else if (item.value.IsSequence())
    for (std::size_t k = 0; k < item.value.size(); ++k) {
      const YAML::Node r = item.value[k];
      if (!r.IsScalar()) loc.fail(r, index(path, k), "expected an entry id, got " + found(r));
      refs.emplace_back(r.Scalar(), r);
    }
  else loc.fail(item.value, path, "expected an entry id or a list of entry ids, got " + found(item.value));

  const std::vector<std::string> earlier(ids.begin(), ids.begin() + i);
  std::vector<std::string> after;
  for (auto& [ref, node] : refs) {
    if (ref == ids[i]) loc.fail(node, path, "an entry cannot run after itself ('" + ref + "')");
    if (one_of(ref, after)) loc.fail(node, path, "'" + ref + "' is listed twice");
    auto later = std::find(ids.begin() + i, ids.end(), ref);
    if (later != ids.end())
      loc.fail(node, path, "'" + ref + "' is " + heads[later - ids.begin()].label +
                               ", declared later; 'after' may only name entries declared before this one");
    if (!one_of(ref, earlier))
      loc.fail(node, path, "unknown id '" + ref + "'" + suggestion(ref, earlier) + " (ids declared before: " +
                               (earlier.empty() ? "none" : join(earlier)) + ")");
    after.push_back(ref);
  }
  return after;
}

// `every: k` or `at: {log: {first: F, factor: X}}` (one of them; neither: every step).
Schedule read_schedule(const Head& h, const Locator& loc) {
  Schedule s;
  const Item* every = find(h.items, "every");
  const Item* at = find(h.items, "at");
  if (every && at)
    loc.fail(at->key_node, h.label + ".at", "give 'every' or 'at', not both (every: k runs on every k-th step; "
                                            "at: {log: {first: 1, factor: 1.2}} on a logarithmic time axis)");
  if (every)
    s.every = std::uint64_t(std::get<std::int64_t>(read_value(
        ParamSpec::integer("every", 1, "").at_least(1), every->value, h.label + ".every", loc)));
  if (!at) return s;
  const std::string path = h.label + ".at";
  const std::vector<Item> kinds = items_of(at->value, path, "a map {log: {first: 1, factor: 1.2}}", loc);
  // The key to blame: the first that is not 'log', else a second 'log' cannot be (items_of).
  const Item* wrong = nullptr;
  for (const Item& k : kinds)
    if (k.key != "log" && !wrong) wrong = &k;
  if (kinds.empty() || wrong)
    loc.fail(kinds.empty() ? at->value : wrong->key_node, path,
             "expected one schedule, 'log' ({log: {first: 1, factor: 1.2}}), got " +
                 (kinds.empty() ? std::string("an empty map")
                                : "'" + wrong->key + "'" + (find(kinds, "log") ? " besides 'log'" : "")));
  const std::vector<ParamSpec> params = {
      ParamSpec::integer("first", 1, "the first step").at_least(1),
      ParamSpec::real("factor", 1.2, "the ratio of successive steps").above(1)};
  const std::string log_path = path + ".log";
  const std::vector<Item> items = items_of(kinds[0].value, log_path, "a map {first: 1, factor: 1.2}", loc);
  const ParamValues v = read_params(kinds[0].value, items, log_path, Schema{params, {}, {}, "key", known_keys(params, {})}, loc);
  s.log = true;
  s.first = std::uint64_t(v.integer("first"));
  s.factor = v.real("factor");
  // Closer to 1 than 1e-9, the exponents k that separate two steps pass 2^53, where k + 1 == k in
  // double: Schedule::log_steps could not list the steps.
  if (s.factor < 1.000000001)
    for (const Item& it : items)
      if (it.key == "factor")
        loc.fail(it.value, log_path + ".factor", "expected a real number of at least 1.000000001, got '" + it.value.Scalar() + "'");
  return s;
}

StepEntry read_entry(std::size_t i, const std::vector<Head>& heads, const std::vector<std::string>& ids,
                     const Registry& reg, const Locator& loc) {
  const Head& h = heads[i];
  const StageDecl& decl = reg.get(h.stage).decl;
  StepEntry e;
  e.id = ids[i];
  e.stage = h.stage;
  e.where = loc.at(h.node);
  InputErrorList errors;  // `after`, the schedule and the parameters are reported together
  if (const Item* after = find(h.items, "after")) {
    errors.attempt([&] { e.after = read_after(*after, i, heads, ids, loc); });
    e.after_given = true;
  }
  errors.attempt([&] { e.schedule = read_schedule(h, loc); });
  std::vector<std::string> names;
  for (auto& p : decl.params) names.push_back(p.name);
  const std::string known = (names.empty() ? "stage '" + h.stage + "' has no parameters"
                                           : "parameters of " + h.stage + ": " + join(names)) +
                            "; entry keys: " + join(kEntryKeys);
  errors.attempt([&] {
    e.params = read_params(h.node, h.items, h.label, Schema{decl.params, kEntryKeys, {}, "parameter", known}, loc);
  });
  errors.raise();
  return e;
}

}  // namespace

std::vector<StepEntry> read_steps(const YAML::Node& n, int dim, const Registry& reg, const Locator& loc) {
  if (!n.IsSequence() || n.size() == 0)
    loc.fail(n, "step", "expected a non-empty list of stage entries ({stage: <name>, ...}), got " +
                            (n.IsSequence() ? std::string("an empty list") : found(n)));
  // Every entry is read, and the errors of all are reported together; an entry whose head (stage,
  // id) is refused is not read further.
  InputErrorList errors;
  std::vector<Head> heads;
  for (std::size_t i = 0; i < n.size(); ++i) {
    heads.push_back(Head{n[i], {}, "", index("step", i)});
    errors.attempt([&] { heads.back() = read_head(n[i], i, dim, reg, loc); });
  }
  const std::vector<std::string> ids = entry_ids(n);
  errors.attempt([&] { check_unique(heads, ids, loc); });
  std::vector<StepEntry> entries;
  for (std::size_t i = 0; i < heads.size(); ++i)
    if (heads[i].read) errors.attempt([&] { entries.push_back(read_entry(i, heads, ids, reg, loc)); });
  errors.raise();
  return entries;
}

}  // namespace ff::pipeline_detail
