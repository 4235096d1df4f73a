// The pipeline loader's shared yaml reading: locating nodes (file position or --set), map
// entries, single checked values and maps of parameters. See core/input/pipeline_yaml.h.
#include "core/input/pipeline_yaml.h"

#include <cstdint>
#include <limits>
#include <optional>

namespace ff::pipeline_detail {

std::string found(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Scalar: return "'" + n.Scalar() + "'";
    case YAML::NodeType::Sequence: return n.size() ? "a list" : "an empty list";
    case YAML::NodeType::Map: return n.size() ? "a map" : "an empty map";
    default: return "nothing";
  }
}

// ---- locating nodes -----------------------------------------------------------------------

namespace {

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

}  // namespace

// Newest override first: a later --set inside a section that an earlier one created is then
// reported as itself.
Location Locator::at(const YAML::Node& n) const {
  for (auto o = overrides_.rbegin(); o != overrides_.rend(); ++o)
    if (contains(o->node, n)) return Location{o->text, 0, 0};
  const YAML::Mark m = n.Mark();
  if (m.is_null()) return Location{file_, 1, 1};  // only the root of an empty document
  return Location{file_, m.line + 1, m.column + 1};
}

// A map entry is reported at its key, unless its value came from --set (the key node of a
// created entry has no position).
Location Locator::at(const Item& item) const {
  Location v = at(item.value);
  return v.line == 0 ? v : at(item.key_node);
}

// The entries of a map in file order; rejects non-maps, non-scalar keys and duplicate keys
// (yaml-cpp keeps both copies of a duplicated key, and would silently use the first).
std::vector<Item> items_of(const YAML::Node& map, const std::string& path, const std::string& expected,
                           const Locator& loc) {
  if (!map.IsMap()) {
    std::optional<std::string> spaced = map.IsScalar() ? with_space_after_colon(map.Scalar()) : std::nullopt;
    loc.fail(map, path, "expected " + expected + ", got " + found(map) +
                            (spaced ? " ('" + map.Scalar() + "' has no space after ':': write '" + *spaced + "')" : ""));
  }
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

// ---- values -------------------------------------------------------------------------------

namespace {

// What a refused scalar probably meant, after "expected X, got 'word'": the word of a fixed set
// it misspells, the boolean YAML 1.1 would have read, that a whole number is too large.
std::string hint(const ParamSpec& spec, const std::string& word) {
  switch (spec.type) {
    case ParamType::string: return suggestion(word, spec.choices);
    case ParamType::boolean:
      if (std::optional<bool> b = yaml11_boolean(word))
        return std::string(" (write ") + (*b ? "true" : "false") + ": YAML 1.2 has no yes/no booleans)";
      return "";
    case ParamType::integer:
      if (is_whole_number_out_of_range(word))
        return " (out of range: the largest integer is " + std::to_string(std::numeric_limits<std::int64_t>::max()) + ")";
      return "";
    default: return "";
  }
}

}  // namespace

// One value checked against its spec: type, range, choices. List items are checked (and
// reported) one by one, with the spec of a single item.
ParamValue read_value(const ParamSpec& spec, const YAML::Node& n, const std::string& path, const Locator& loc) {
  if (spec.type == ParamType::per_type && n.IsScalar()) {  // one value for every type
    ParamSpec item = spec;
    item.type = ParamType::real;
    return ParamValue(std::vector<double>{std::get<double>(read_value(item, n, path, loc))});
  }
  const bool is_list = spec.type == ParamType::string_list || spec.type == ParamType::real_list ||
                       spec.type == ParamType::per_type;
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
    loc.fail(n, path, "expected " + spec.expectation() + ", got " + found(n) + (n.IsScalar() ? hint(spec, n.Scalar()) : ""));
  return *v;
}

// ---- maps of parameters -------------------------------------------------------------------

namespace {

const ParamSpec* spec_of(const Schema& s, const std::string& key) {
  for (auto& p : s.params)
    if (p.name == key) return &p;
  return nullptr;
}

}  // namespace

ParamValues read_params(const YAML::Node& map, const std::vector<Item>& items, const std::string& path,
                        const Schema& schema, const Locator& loc) {
  ParamValues values;
  InputErrorList errors;  // every wrong key of the map, not only the first
  for (auto& item : items) errors.attempt([&] {
    if (one_of(item.key, schema.reserved)) return;
    const ParamSpec* spec = spec_of(schema, item.key);
    if (!spec) {
      std::vector<std::string> words = schema.reserved;
      for (auto& p : schema.params) words.push_back(p.name);
      // {v0:1.0} in a flow map is one key, 'v0:1.0', with no value.
      const std::optional<std::string> spaced = with_space_after_colon(item.key);
      fail(loc.at(item), child(path, item.key),
           "unknown " + schema.kind +
               (spaced ? "; '" + item.key + "' looks like '" + *spaced + "' with no space after ':'"
                       : suggestion(item.key, words)) +
               " (" + schema.known + ")");
    }
    values.set(item.key, read_value(*spec, item.value, child(path, item.key), loc));
  });
  for (auto& spec : schema.params) {
    if (values.has(spec.name) || one_of(spec.name, schema.optional)) continue;
    if (find(items, spec.name)) continue;  // given, and refused above
    if (!spec.default_value) {
      errors.attempt([&] {
        loc.fail(map, path, "missing required " + schema.kind + " '" + spec.name + "' (" + spec.expectation() + ")");
      });
      continue;
    }
    values.set(spec.name, *spec.default_value);
  }
  errors.raise();
  return values;
}

std::string known_keys(const std::vector<ParamSpec>& params, const std::vector<std::string>& extra) {
  std::vector<std::string> k;
  for (auto& p : params) k.push_back(p.name);
  k.insert(k.end(), extra.begin(), extra.end());
  return "known keys: " + join(k);
}

}  // namespace ff::pipeline_detail
