// The yaml-free words of the pipeline loader: see core/input/pipeline_words.h.
#include "core/input/pipeline_words.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <regex>

#include "core/base/error.h"

namespace ff::pipeline_detail {

// ---- words for messages -------------------------------------------------------------------

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

bool one_of(const std::string& s, const std::vector<std::string>& v) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

std::string child(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }
std::string index(const std::string& path, std::size_t i) { return path + "[" + std::to_string(i) + "]"; }

[[noreturn]] void fail(const Location& at, const std::string& path, const std::string& what) {
  throw InputError(at.str() + ": " + (path.empty() ? "" : path + ": ") + what);
}

// ---- scalars ------------------------------------------------------------------------------

bool is_number(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

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
  // Every double from 2^53 up is a whole number, and one below 2^63 converts exactly; the same
  // largest integer whichever way it is written.
  std::optional<double> d = to_real(s);
  if (!d || std::floor(*d) != *d || !(std::fabs(*d) < 9223372036854775808.0)) return std::nullopt;  // 2^63
  return static_cast<std::int64_t>(*d);
}

bool is_whole_number_out_of_range(const std::string& s) {
  static const std::regex integer(R"([+-]?\d+)");
  if (std::regex_match(s, integer)) return !to_integer(s);
  if (std::optional<double> d = to_real(s)) return std::floor(*d) == *d && !to_integer(s);
  // Past DBL_MAX ("1e400") to_real gives up too; the notation still says a number.
  static const std::regex real(R"([+-]?(\d+(\.\d*)?|\.\d+)[eE]\+?\d+)");
  return std::regex_match(s, real);
}

std::optional<bool> to_boolean(const std::string& s) {
  if (s == "true" || s == "True" || s == "TRUE") return true;
  if (s == "false" || s == "False" || s == "FALSE") return false;
  return std::nullopt;
}

// YAML 1.1's booleans, which YAML 1.2 (and so this loader) reads as plain words.
std::optional<bool> yaml11_boolean(const std::string& s) {
  for (const char* w : {"yes", "Yes", "YES", "on", "On", "ON", "y", "Y"})
    if (s == w) return true;
  for (const char* w : {"no", "No", "NO", "off", "Off", "OFF", "n", "N"})
    if (s == w) return false;
  return std::nullopt;
}

// "N:4096" -> "N: 4096": a key and its value that YAML read as one word, for want of the space
// after ':'. Not a URL ("http://...") nor a C++-style name ("a::b").
std::optional<std::string> with_space_after_colon(const std::string& s) {
  static const std::regex joined(R"(([A-Za-z_][A-Za-z0-9_.\-]*):([^\s:].*))");
  std::smatch m;
  if (!std::regex_match(s, m, joined) || m[2].str().rfind("//", 0) == 0) return std::nullopt;
  return m[1].str() + ": " + m[2].str();
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

}  // namespace ff::pipeline_detail
