// Stage parameters: a stage declares a schema (name, type, default, range, doc); the pipeline
// loader validates the YAML against it (errors name file:line:column, key and expectation) and
// hands the stage a ParamValues with every declared key present. nvcc-clean.
#pragma once
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace ff {

enum class ParamType : std::uint8_t { real, integer, boolean, string, string_list, real_list };
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

  // "a real number > 0", "one of [a, b]", ... — used in error messages and `describe`.
  std::string expectation() const;
};

// Check a value against the spec; returns an empty string when fine, else what was expected.
std::string check_param(const ParamSpec& spec, const ParamValue& v);
std::string format_value(const ParamValue& v);

class ParamValues {
 public:
  void set(const std::string& key, ParamValue v) { values_[key] = std::move(v); }
  bool has(const std::string& key) const { return values_.count(key) != 0; }
  double real(const std::string& key) const;
  std::int64_t integer(const std::string& key) const;
  bool boolean(const std::string& key) const;
  const std::string& string(const std::string& key) const;
  const std::vector<std::string>& strings(const std::string& key) const;
  const std::vector<double>& reals(const std::string& key) const;
  const std::map<std::string, ParamValue>& all() const { return values_; }

  // Every declared key with its default (what a stage sees when the YAML gives nothing).
  static ParamValues defaults(const std::vector<ParamSpec>& specs);

 private:
  const ParamValue& get(const std::string& key) const;
  std::map<std::string, ParamValue> values_;
};

}  // namespace ff
