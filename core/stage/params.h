// Stage parameters: a stage declares a schema (name, type, default, range, doc); the pipeline
// loader validates the YAML against it (errors name file:line:column, key and expectation) and
// hands the stage a ParamValues with every declared key present. nvcc-clean.
#pragma once
#include <cstdint>
#include <initializer_list>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace ff {

// per_type: a real number for every particle type, or one per type (system.types); held as a
// list of reals (a single number is a list of one). PerType resolves it against the types.
enum class ParamType : std::uint8_t { real, integer, boolean, string, string_list, real_list, per_type };
const char* to_string(ParamType t);

using ParamValue =
    std::variant<double, std::int64_t, bool, std::string, std::vector<std::string>, std::vector<double>>;

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::real;
  std::optional<ParamValue> default_value;  // none = required
  std::optional<double> min, max;            // inclusive bounds for real/integer (and list items)
  bool min_exclusive = false;
  std::vector<std::string> choices;          // allowed strings (string / string_list)
  std::string doc;

  // Builders keep declarations one line each in plugin.cpp.
  static ParamSpec real(std::string name, std::optional<double> def, std::string doc);
  static ParamSpec integer(std::string name, std::optional<std::int64_t> def, std::string doc);
  static ParamSpec boolean(std::string name, bool def, std::string doc);
  static ParamSpec string(std::string name, std::optional<std::string> def, std::string doc);
  static ParamSpec strings(std::string name, std::vector<std::string> def, std::string doc);
  ParamSpec& at_least(double v) { min = v; return *this; }
  ParamSpec& above(double v) { min = v; min_exclusive = true; return *this; }
  ParamSpec& at_most(double v) { max = v; return *this; }
  ParamSpec& one_of(std::vector<std::string> c) { choices = std::move(c); return *this; }
  // No default: the pipeline must give it.
  ParamSpec& required() { default_value.reset(); return *this; }

  // "a real number > 0", "one of [a, b]", ... — used in error messages and `describe`.
  std::string expectation() const;
};

// Check a value against the spec; returns an empty string when fine, else what was expected.
std::string check_param(const ParamSpec& spec, const ParamValue& v);
std::string format_value(const ParamValue& v);
// As the pipeline file would write it for this spec (a per_type value of one number: the number).
std::string format_value(const ParamSpec& spec, const ParamValue& v);

class ParamValues {
 public:
  void set(const std::string& key, ParamValue v) { values_[key] = std::move(v); }
  bool has(const std::string& key) const { return values_.count(key) != 0; }
  double real(const std::string& key) const;
  std::int64_t integer(const std::string& key) const;
  bool boolean(const std::string& key) const;
  const std::string& string(const std::string& key) const;
  const std::vector<std::string>& strings(const std::string& key) const;
  // A list of reals; a single real (a per_type parameter set from code) is a list of one.
  std::vector<double> reals(const std::string& key) const;
  const std::map<std::string, ParamValue>& all() const { return values_; }

  // Every declared key with its default (what a stage sees when the YAML gives nothing).
  static ParamValues defaults(const std::vector<ParamSpec>& specs);

 private:
  const ParamValue& get(const std::string& key) const;
  std::map<std::string, ParamValue> values_;
};

// ParamValues written inline: param_values({{"k", 100.0}, {"field", std::vector<double>{1, 0}}}),
// what a test hands a stage and an alias (core/stage/stage_registration.h) fixes.
inline ParamValues param_values(std::initializer_list<std::pair<const char*, ParamValue>> kv) {
  ParamValues v;
  for (auto& p : kv) v.set(p.first, p.second);
  return v;
}

// A per_type parameter's values: one for every type, or one per type.
struct PerType {
  std::vector<double> values{1.0};
  double operator[](std::size_t type) const { return values.size() == 1 ? values[0] : values[type]; }
  bool uniform() const { return values.size() == 1; }
};

// Parameters described once. A stage's parameter struct holds each parameter as a member
// initialised to its default, and names it once, with its documentation and bounds, in
// describe():
//
//   struct IntegrateParams {
//     double v0 = 1.0;
//     template <class D> void describe(D& d) {
//       d(v0, "v0", "self-propulsion speed (σ/τ)").at_least(0);
//     }
//   };
//
// schema_of<P>() is the ParamSpec list (defaults taken from the members); params_from<P>(values)
// the struct filled from validated values. Member types: double, std::int64_t, bool,
// std::string, std::vector<std::string>, std::vector<double>, PerType.
namespace param_detail {
class Schema {
 public:
  ParamSpec& operator()(double& m, const char* name, const char* doc) { return add(ParamSpec::real(name, m, doc)); }
  ParamSpec& operator()(std::int64_t& m, const char* name, const char* doc) {
    return add(ParamSpec::integer(name, m, doc));
  }
  ParamSpec& operator()(bool& m, const char* name, const char* doc) { return add(ParamSpec::boolean(name, m, doc)); }
  ParamSpec& operator()(std::string& m, const char* name, const char* doc) {
    return add(ParamSpec::string(name, m, doc));
  }
  ParamSpec& operator()(std::vector<std::string>& m, const char* name, const char* doc) {
    return add(ParamSpec::strings(name, m, doc));
  }
  ParamSpec& operator()(std::vector<double>& m, const char* name, const char* doc) {
    return add(list(name, ParamType::real_list, m, doc));
  }
  ParamSpec& operator()(PerType& m, const char* name, const char* doc) {
    return add(list(name, ParamType::per_type, m.values, doc));
  }
  std::vector<ParamSpec> specs;

 private:
  static ParamSpec list(const char* name, ParamType t, const std::vector<double>& def, const char* doc) {
    ParamSpec s;
    s.name = name;
    s.type = t;
    s.default_value = def;
    s.doc = doc;
    return s;
  }
  ParamSpec& add(ParamSpec s) {
    specs.push_back(std::move(s));
    return specs.back();
  }
};

class Read {
 public:
  explicit Read(const ParamValues& v) : v_(v) {}
  // A key the values lack (a stage built from code with only some parameters) keeps the
  // member's default; the pipeline loader always gives every key.
  ParamSpec& operator()(double& m, const char* name, const char*) { return get(m, name, &ParamValues::real); }
  ParamSpec& operator()(std::int64_t& m, const char* name, const char*) { return get(m, name, &ParamValues::integer); }
  ParamSpec& operator()(bool& m, const char* name, const char*) { return get(m, name, &ParamValues::boolean); }
  ParamSpec& operator()(std::string& m, const char* name, const char*) { return get(m, name, &ParamValues::string); }
  ParamSpec& operator()(std::vector<std::string>& m, const char* name, const char*) {
    return get(m, name, &ParamValues::strings);
  }
  ParamSpec& operator()(std::vector<double>& m, const char* name, const char*) {
    return get(m, name, &ParamValues::reals);
  }
  ParamSpec& operator()(PerType& m, const char* name, const char*) { return get(m.values, name, &ParamValues::reals); }

 private:
  template <class T, class Getter>
  ParamSpec& get(T& m, const char* name, Getter getter) {
    if (v_.has(name)) m = (v_.*getter)(name);
    return ignored_;
  }
  const ParamValues& v_;
  ParamSpec ignored_;  // the bounds chained after a member only matter to the schema
};
}  // namespace param_detail

template <class P>
std::vector<ParamSpec> schema_of() {
  P p;
  param_detail::Schema s;
  p.describe(s);
  return s.specs;
}

template <class P>
P params_from(const ParamValues& values) {
  P p;
  param_detail::Read r(values);
  p.describe(r);
  return p;
}

}  // namespace ff
