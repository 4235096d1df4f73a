// YAML pipeline files -> PipelineSpec. The only core file that knows yaml-cpp.
//
// Every error is an InputError "WHERE: PATH: what was expected, got what was found", where
// WHERE is "file:line:column" (1-based) or "--set key=value" for a node that an override
// produced, and PATH is the key path ("run.dt", "step[2] (delaunay.lawson).max_rounds").
// The system and run sections are checked with the same ParamSpec machinery as stage
// parameters, so all sections word their errors the same way.
#include "core/pipeline_loader.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <regex>

#include "core/error.h"

namespace ff {

std::string Location::str() const {
  if (line <= 0) return file;
  return file + ":" + std::to_string(line) + ":" + std::to_string(column);
}

namespace {

// ---- words for messages -------------------------------------------------------------------

const std::vector<std::string> kTopKeys = {"system", "run", "plugins", "step"};
const std::vector<std::string> kEntryKeys = {"stage", "id", "after", "every"};

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

bool one_of(const std::string& s, const std::vector<std::string>& v) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

// Optimal-string-alignment distance: typos are mostly one insertion, deletion, substitution or
// swap of neighbours, and a swap should cost one, not two.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
    for (std::size_t j = 1; j <= b.size(); ++j) {
      std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

// "; did you mean 'x'?" when one known word is a plausible typo of `word` (about one edit per
// three letters), else "". Suggesting a word that shares nothing with the input only confuses.
std::string suggestion(const std::string& word, const std::vector<std::string>& known) {
  const std::size_t allowed = std::max<std::size_t>(1, word.size() / 3);
  const std::string* best = nullptr;
  std::size_t best_d = allowed + 1;
  for (auto& k : known) {
    std::size_t d = edit_distance(word, k);
    if (d < best_d) best_d = d, best = &k;
  }
  return best ? "; did you mean '" + *best + "'?" : "";
}

std::string found(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Scalar: return "'" + n.Scalar() + "'";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Map: return "a map";
    default: return "nothing";
  }
}

std::string child(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }
std::string index(const std::string& path, std::size_t i) { return path + "[" + std::to_string(i) + "]"; }

[[noreturn]] void fail(const Location& at, const std::string& path, const std::string& what) {
  throw InputError(at.str() + ": " + (path.empty() ? "" : path + ": ") + what);
}

// ---- locating nodes -----------------------------------------------------------------------

// A subtree that came from --set, with the text that produced it.
struct Override {
  YAML::Node node;
  std::string text;  // "--set run.dt=abc"
};

// Depth-limited: an alias inside its own anchor ("&a [*a]") makes a cycle.
bool contains(const YAML::Node& tree, const YAML::Node& n, int depth = 0) {
  if (tree.is(n)) return true;
  if (depth > 32) return false;
  if (tree.IsSequence())
    for (const auto& c : tree)
      if (contains(c, n, depth + 1)) return true;
  if (tree.IsMap())
    for (const auto& kv : tree)
      if (contains(kv.first, n, depth + 1) || contains(kv.second, n, depth + 1)) return true;
  return false;
}

struct Item {
  std::string key;
  YAML::Node key_node, value;
};

class Locator {
 public:
  Locator(const std::string& file, const std::vector<Override>& overrides) : file_(file), overrides_(overrides) {}

  // Newest override first: a later --set inside a section that an earlier one created is
  // then reported as itself.
  Location at(const YAML::Node& n) const {
    for (auto o = overrides_.rbegin(); o != overrides_.rend(); ++o)
      if (contains(o->node, n)) return Location{o->text, 0, 0};
    const YAML::Mark m = n.Mark();
    if (m.is_null()) return Location{file_, 1, 1};  // only the root of an empty document
    return Location{file_, m.line + 1, m.column + 1};
  }
  // A map entry is reported at its key, unless its value came from --set (the key node of a
  // created entry has no position).
  Location at(const Item& item) const {
    Location v = at(item.value);
    return v.line == 0 ? v : at(item.key_node);
  }
  [[noreturn]] void fail(const YAML::Node& n, const std::string& path, const std::string& what) const {
    ff::fail(at(n), path, what);
  }

 private:
  const std::string& file_;
  const std::vector<Override>& overrides_;
};

// The entries of a map in file order; rejects non-maps, non-scalar keys and duplicate keys
// (yaml-cpp keeps both copies of a duplicated key, and would silently use the first).
std::vector<Item> items_of(const YAML::Node& map, const std::string& path, const std::string& expected,
                           const Locator& loc) {
  if (!map.IsMap()) loc.fail(map, path, "expected " + expected + ", got " + found(map));
  std::vector<Item> items;
  for (const auto& kv : map) {
    if (!kv.second.IsDefined()) continue;
    if (!kv.first.IsScalar()) loc.fail(kv.first, path, "expected a key name, got " + found(kv.first));
    const std::string key = kv.first.Scalar();
    for (auto& prev : items)
      if (prev.key == key)
        loc.fail(kv.first, child(path, key), "duplicate key (first given at " + loc.at(prev.key_node).str() + ")");
    items.push_back({key, kv.first, kv.second});
  }
  return items;
}

const Item* find(const std::vector<Item>& items, const std::string& key) {
  for (auto& i : items)
    if (i.key == key) return &i;
  return nullptr;
}

// ---- scalars ------------------------------------------------------------------------------

// Plain decimal notation only: YAML's .inf/.nan, hex and C's "inf" are not numbers a user
// means for a physical parameter.
std::optional<double> to_real(std::string s) {
  static const std::regex real(R"([+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?)");
  if (!std::regex_match(s, real)) return std::nullopt;
  if (s[0] == '+') s.erase(0, 1);  // from_chars takes no '+'
  double v = 0;
  auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// Decimal integers, and real notation that is exactly an integer ("1e4"); never "1.5".
std::optional<std::int64_t> to_integer(std::string s) {
  static const std::regex integer(R"([+-]?\d+)");
  if (std::regex_match(s, integer)) {
    if (s[0] == '+') s.erase(0, 1);
    std::int64_t v = 0;
    auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    if (r.ec != std::errc()) return std::nullopt;  // out of range
    return v;
  }
  std::optional<double> d = to_real(s);
  if (!d || std::floor(*d) != *d || std::fabs(*d) > 9007199254740992.0) return std::nullopt;  // 2^53
  return static_cast<std::int64_t>(*d);
}

std::optional<bool> to_boolean(const std::string& s) {
  if (s == "true" || s == "True" || s == "TRUE") return true;
  if (s == "false" || s == "False" || s == "FALSE") return false;
  return std::nullopt;
}

std::optional<ParamValue> to_scalar_value(ParamType type, const std::string& s) {
  switch (type) {
    case ParamType::real:
      if (auto v = to_real(s)) return ParamValue(*v);
      break;
    case ParamType::integer:
      if (auto v = to_integer(s)) return ParamValue(*v);
      break;
    case ParamType::boolean:
      if (auto v = to_boolean(s)) return ParamValue(*v);
      break;
    case ParamType::string: return ParamValue(s);
    default: break;
  }
  return std::nullopt;
}

// One value checked against its spec: type, range, choices. List items are checked (and
// reported) one by one, with the spec of a single item.
ParamValue read_value(const ParamSpec& spec, const YAML::Node& n, const std::string& path, const Locator& loc) {
  const bool is_list = spec.type == ParamType::string_list || spec.type == ParamType::real_list;
  if (is_list) {
    if (!n.IsSequence()) loc.fail(n, path, "expected " + spec.expectation() + ", got " + found(n));
    ParamSpec item = spec;
    item.type = spec.type == ParamType::string_list ? ParamType::string : ParamType::real;
    std::vector<std::string> strings;
    std::vector<double> reals;
    for (std::size_t i = 0; i < n.size(); ++i) {
      ParamValue v = read_value(item, n[i], index(path, i), loc);
      if (auto* s = std::get_if<std::string>(&v)) strings.push_back(*s);
      else reals.push_back(std::get<double>(v));
    }
    return spec.type == ParamType::string_list ? ParamValue(strings) : ParamValue(reals);
  }
  std::optional<ParamValue> v;
  if (n.IsScalar()) v = to_scalar_value(spec.type, n.Scalar());
  if (!v || !check_param(spec, *v).empty())
    loc.fail(n, path, "expected " + spec.expectation() + ", got " + found(n));
  return *v;
}

// ---- maps of parameters -------------------------------------------------------------------

// How a map of parameters is checked: its schema, the keys the caller reads itself, the
// declared keys that are optional without a default, and the words for errors.
struct Schema {
  std::vector<ParamSpec> params;
  std::vector<std::string> reserved;
  std::vector<std::string> optional;
  std::string kind = "key";  // "key" | "parameter"
  std::string known;         // listed after an unknown key
};

const ParamSpec* spec_of(const Schema& s, const std::string& key) {
  for (auto& p : s.params)
    if (p.name == key) return &p;
  return nullptr;
}

ParamValues read_params(const YAML::Node& map, const std::vector<Item>& items, const std::string& path,
                        const Schema& schema, const Locator& loc) {
  ParamValues values;
  for (auto& item : items) {
    if (one_of(item.key, schema.reserved)) continue;
    const ParamSpec* spec = spec_of(schema, item.key);
    if (!spec) {
      std::vector<std::string> words = schema.reserved;
      for (auto& p : schema.params) words.push_back(p.name);
      fail(loc.at(item), child(path, item.key),
           "unknown " + schema.kind + suggestion(item.key, words) + " (" + schema.known + ")");
    }
    values.set(item.key, read_value(*spec, item.value, child(path, item.key), loc));
  }
  for (auto& spec : schema.params) {
    if (values.has(spec.name) || one_of(spec.name, schema.optional)) continue;
    if (!spec.default_value)
      loc.fail(map, path, "missing required " + schema.kind + " '" + spec.name + "' (" + spec.expectation() + ")");
    values.set(spec.name, *spec.default_value);
  }
  return values;
}

std::string known_keys(const std::vector<ParamSpec>& params, const std::vector<std::string>& extra) {
  std::vector<std::string> k;
  for (auto& p : params) k.push_back(p.name);
  k.insert(k.end(), extra.begin(), extra.end());
  return "known keys: " + join(k);
}

// ---- top level, system, run, plugins --------------------------------------------------------

std::vector<Item> top_level(const YAML::Node& root, const Locator& loc) {
  auto items = items_of(root, "", "a map with keys " + join(kTopKeys), loc);
  for (auto& item : items)
    if (!one_of(item.key, kTopKeys))
      fail(loc.at(item), item.key,
           "unknown top-level key" + suggestion(item.key, kTopKeys) + " (known keys: " + join(kTopKeys) + ")");
  for (const char* key : {"system", "run", "step"})
    if (!find(items, key)) loc.fail(root, "", std::string("missing required top-level key '") + key + "'");
  return items;
}

ParamSpec real_list(std::string name, std::string doc) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = ParamType::real_list;
  s.doc = std::move(doc);
  return s;
}

const std::vector<ParamSpec>& system_schema() {
  static const std::vector<ParamSpec> s = {
      ParamSpec::integer("dimensions", 2, "2 or 3").at_least(2).at_most(3),
      ParamSpec::integer("N", std::nullopt, "number of particles").at_least(1),
      // Also < 1, checked after: ParamSpec bounds are inclusive at the top.
      ParamSpec::real("packing_fraction", std::nullopt, "area/volume fraction; sets the box").above(0),
      real_list("box", "edge lengths, one per dimension").above(0),
      ParamSpec::real("sigma", 1.0, "reference diameter").above(0),
      ParamSpec::string("init", "random", "initial positions")
          .one_of({"random", "triangular_lattice_sample", "lattice_sample"}),
  };
  return s;
}

const std::vector<ParamSpec>& species_schema() {
  static const std::vector<ParamSpec> s = {
      ParamSpec::string("name", std::nullopt, "species name"),
      ParamSpec::real("fraction", std::nullopt, "share of N (normalised)").above(0),
      ParamSpec::real("diameter", 1.0, "in units of sigma").above(0),
  };
  return s;
}

const std::vector<ParamSpec>& run_schema() {
  static const std::vector<ParamSpec> s = {
      ParamSpec::integer("steps", std::nullopt, "steps to run").at_least(0),
      ParamSpec::real("dt", std::nullopt, "nominal time step").above(0),
      ParamSpec::real("dt_min", std::nullopt, "smallest Δt before giving up (default dt/1024)").above(0),
      ParamSpec::integer("dt_grow_after", 100, "good steps before Δt doubles back").at_least(1),
      ParamSpec::integer("seed", 0, "random seed").at_least(0),
      ParamSpec::string("precision", "double", "real type").one_of({"float", "double"}),
  };
  return s;
}

std::vector<SpeciesSpec> read_types(const YAML::Node& n, const Locator& loc) {
  const std::string path = "system.types";
  const std::string expected = "a non-empty list of maps {name, fraction, diameter}";
  if (!n.IsSequence() || n.size() == 0) loc.fail(n, path, "expected " + expected + ", got " + found(n));
  const Schema schema{species_schema(), {}, {}, "key", known_keys(species_schema(), {})};
  std::vector<SpeciesSpec> types;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string at = index(path, i);
    ParamValues v = read_params(n[i], items_of(n[i], at, "a map {name, fraction, diameter}", loc), at, schema, loc);
    for (auto& t : types)
      if (t.name == v.string("name")) loc.fail(n[i], at, "species '" + t.name + "' is listed twice");
    types.push_back(SpeciesSpec{v.string("name"), v.real("fraction"), v.real("diameter")});
  }
  return types;
}

// Exactly one of box / packing_fraction sets the box; a box has one edge per dimension.
void check_box(SystemSpec& s, const YAML::Node& map, const std::vector<Item>& items, const Locator& loc) {
  const Item* box = find(items, "box");
  const Item* pf = find(items, "packing_fraction");
  if (box && pf) {
    // Blame an override if one of them is, else the one given second.
    const Location b = loc.at(*box), p = loc.at(*pf);
    const bool box_second = b.line > p.line || (b.line == p.line && b.column > p.column);
    const bool blame_box = b.line == 0 || (p.line != 0 && box_second);
    fail(blame_box ? b : p, "system", "give either 'box' or 'packing_fraction', not both");
  }
  if (!box && !pf) loc.fail(map, "system", "missing 'packing_fraction' or 'box' (one of them sets the box)");
  if (pf && s.packing_fraction >= 1)
    loc.fail(pf->value, "system.packing_fraction", "expected a real number > 0 and < 1, got " + found(pf->value));
  if (box && s.box.size() != std::size_t(s.dimensions))
    loc.fail(box->value, "system.box",
             "expected " + std::to_string(s.dimensions) + " edge lengths (one per dimension; system.dimensions is " +
                 std::to_string(s.dimensions) + "), got " + std::to_string(s.box.size()));
}

SystemSpec read_system(const YAML::Node& n, const Locator& loc) {
  auto items = items_of(n, "system", "a map of system settings", loc);
  const Schema schema{system_schema(), {"types"}, {"packing_fraction", "box"}, "key",
                      known_keys(system_schema(), {"types"})};
  ParamValues v = read_params(n, items, "system", schema, loc);
  SystemSpec s;
  s.dimensions = int(v.integer("dimensions"));
  s.N = std::uint64_t(v.integer("N"));
  if (v.has("packing_fraction")) s.packing_fraction = v.real("packing_fraction");
  if (v.has("box")) s.box = v.reals("box");
  s.sigma = v.real("sigma");
  s.init = v.string("init");
  if (const Item* t = find(items, "types")) s.types = read_types(t->value, loc);
  check_box(s, n, items, loc);
  return s;
}

RunSpec read_run(const YAML::Node& n, const Locator& loc) {
  auto items = items_of(n, "run", "a map of run settings", loc);
  const Schema schema{run_schema(), {}, {"dt_min"}, "key", known_keys(run_schema(), {})};
  ParamValues v = read_params(n, items, "run", schema, loc);
  RunSpec r;
  r.steps = std::uint64_t(v.integer("steps"));
  r.dt = v.real("dt");
  r.dt_min = v.has("dt_min") ? v.real("dt_min") : r.dt / 1024;
  if (r.dt_min > r.dt) {
    const YAML::Node& at = find(items, "dt_min")->value;
    loc.fail(at, "run.dt_min",
             "expected a real number > 0 and <= run.dt (" + format_value(r.dt) + "), got " + found(at));
  }
  r.dt_grow_after = std::uint64_t(v.integer("dt_grow_after"));
  r.seed = std::uint64_t(v.integer("seed"));
  r.precision = v.string("precision") == "float" ? Precision::f32 : Precision::f64;
  return r;
}

std::vector<std::string> read_plugins(const Item* item, const Locator& loc) {
  if (!item) return {};
  return std::get<std::vector<std::string>>(
      read_value(ParamSpec::strings("plugins", {}, "plugin libraries"), item->value, "plugins", loc));
}

// ---- step entries -------------------------------------------------------------------------

// A const lookup of a missing key gives an invalid node, on which Type() throws.
bool scalar_in(const YAML::Node& map, const char* key) {
  if (!map.IsMap()) return false;
  const YAML::Node v = map[key];
  return v.IsDefined() && v.IsScalar();
}

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

bool is_number(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// What the first pass learns about an entry: enough to name it and to resolve `after`.
struct Head {
  YAML::Node node;
  std::vector<Item> items;
  std::string stage, label;  // label: "step[2] (delaunay.lawson)"
};

Head read_head(const YAML::Node& e, std::size_t i, int dim, const Registry& reg, const Locator& loc) {
  const std::string at = index("step", i);
  Head h{e, items_of(e, at, "a map with at least 'stage: <name>'", loc), {}, at};
  const Item* stage = find(h.items, "stage");
  if (!stage) loc.fail(e, at, "missing required key 'stage' (the name of a loaded stage)");
  h.stage = std::get<std::string>(read_value(ParamSpec::string("stage", std::nullopt, ""), stage->value,
                                             at + ".stage", loc));
  if (!reg.has(h.stage)) {
    const std::string s = suggestion(h.stage, reg.names());
    loc.fail(stage->value, at + ".stage",
             "unknown stage '" + h.stage + "'" + s + " (loaded stages: " + join(reg.names()) + ")" +
                 (s.empty() ? "; is its plugin listed under 'plugins'?" : ""));
  }
  const StageDecl& decl = reg.get(h.stage).decl;
  if (!std::count(decl.dimensions.begin(), decl.dimensions.end(), dim)) {
    std::vector<std::string> dims;
    for (int d : decl.dimensions) dims.push_back(std::to_string(d));
    loc.fail(stage->value, at + ".stage",
             "stage '" + h.stage + "' supports dimensions " + join(dims) + " only, but system.dimensions is " +
                 std::to_string(dim));
  }
  h.label = at + " (" + h.stage + ")";
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
      if (ids[i] == ids[j]) {
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

StepEntry read_entry(std::size_t i, const std::vector<Head>& heads, const std::vector<std::string>& ids,
                     const Registry& reg, const Locator& loc) {
  const Head& h = heads[i];
  const StageDecl& decl = reg.get(h.stage).decl;
  StepEntry e;
  e.id = ids[i];
  e.stage = h.stage;
  e.where = loc.at(h.node);
  if (const Item* after = find(h.items, "after")) {
    e.after = read_after(*after, i, heads, ids, loc);
    e.after_given = true;
  }
  if (const Item* every = find(h.items, "every"))
    e.every = std::uint64_t(std::get<std::int64_t>(read_value(
        ParamSpec::integer("every", 1, "").at_least(1), every->value, h.label + ".every", loc)));
  std::vector<std::string> names;
  for (auto& p : decl.params) names.push_back(p.name);
  const std::string known = (names.empty() ? "stage '" + h.stage + "' has no parameters"
                                           : "parameters of " + h.stage + ": " + join(names)) +
                            "; entry keys: " + join(kEntryKeys);
  e.params = read_params(h.node, h.items, h.label, Schema{decl.params, kEntryKeys, {}, "parameter", known}, loc);
  return e;
}

std::vector<StepEntry> read_steps(const YAML::Node& n, int dim, const Registry& reg, const Locator& loc) {
  if (!n.IsSequence() || n.size() == 0)
    loc.fail(n, "step", "expected a non-empty list of stage entries ({stage: <name>, ...}), got " +
                            (n.IsSequence() ? std::string("an empty list") : found(n)));
  std::vector<Head> heads;
  for (std::size_t i = 0; i < n.size(); ++i) heads.push_back(read_head(n[i], i, dim, reg, loc));
  const std::vector<std::string> ids = entry_ids(n);
  check_unique(heads, ids, loc);
  std::vector<StepEntry> entries;
  for (std::size_t i = 0; i < heads.size(); ++i) entries.push_back(read_entry(i, heads, ids, reg, loc));
  return entries;
}

}  // namespace

// ---- the document -------------------------------------------------------------------------

struct PipelineDocument::Impl {
  std::string file;
  YAML::Node root;
  std::vector<Override> overrides;

  Locator locator() const { return Locator(file, overrides); }
  void apply(const std::string& text);

 private:
  YAML::Node section(const std::string& name, const std::string& where);
  YAML::Node entry(const std::string& x, const std::string& where);
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

// step.<x>: an index, or an entry id (as entry_ids() numbers them).
YAML::Node PipelineDocument::Impl::entry(const std::string& x, const std::string& where) {
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
    if (it == ids.end())
      bad_override(where, "no step entry with id '" + x + "'" + suggestion(x, ids) + " (ids: " + join(ids) + ")");
    i = std::size_t(it - ids.begin());
  }
  YAML::Node e = steps[i];
  if (!e.IsMap()) locator().fail(e, index("step", i), "expected a map with at least 'stage: <name>', got " + found(e));
  return e;
}

void PipelineDocument::Impl::apply(const std::string& text) {
  const std::string where = "--set " + text;
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    bad_override(where, "expected KEY.PATH=VALUE, e.g. --set run.dt=0.001");
  const std::string key = text.substr(0, eq);
  YAML::Node value;
  try {
    value = YAML::Load(text.substr(eq + 1));
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
    YAML::Node e = entry(rest.substr(0, last), where);
    e[rest.substr(last + 1)] = value;
  } else if (one_of(head, kTopKeys)) {
    bad_override(where, "expected one of " + forms);
  } else {
    bad_override(where, "unknown section '" + head + "'" + suggestion(head, kTopKeys) + " (expected one of " +
                            forms + ")");
  }
  overrides.push_back({value, where});
}

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
    fail(Location{name, e.mark.line + 1, e.mark.column + 1}, "", "invalid YAML: " + e.msg);
  }
  // The root must be a map before overrides can write into it; an empty file becomes one.
  if (impl->root.IsDefined() && !impl->root.IsNull() && !impl->root.IsMap())
    impl->locator().fail(impl->root, "", "expected a map with keys " + join(kTopKeys) + ", got " + found(impl->root));
  for (auto& o : overrides) impl->apply(o);
  top_level(impl->root, impl->locator());
  return PipelineDocument(std::move(impl));
}

std::vector<std::string> PipelineDocument::plugins() const {
  const Locator loc = impl_->locator();
  return read_plugins(find(top_level(impl_->root, loc), "plugins"), loc);
}

PipelineSpec PipelineDocument::resolve(const Registry& registry) const {
  const Locator loc = impl_->locator();
  const std::vector<Item> top = top_level(impl_->root, loc);
  PipelineSpec spec;
  spec.file = impl_->file;
  spec.system = read_system(find(top, "system")->value, loc);
  spec.run = read_run(find(top, "run")->value, loc);
  spec.plugins = read_plugins(find(top, "plugins"), loc);
  spec.step = read_steps(find(top, "step")->value, spec.system.dimensions, registry, loc);
  return spec;
}

}  // namespace ff
