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

}  // namespace ff::pipeline_detail
