#include "core/stage/params.h"

#include <sstream>
#include <stdexcept>

namespace ff {

const char* to_string(ParamType t) {
  switch (t) {
    case ParamType::real: return "real";
    case ParamType::integer: return "integer";
    case ParamType::boolean: return "boolean";
    case ParamType::string: return "string";
    case ParamType::string_list: return "list of strings";
    case ParamType::real_list: return "list of reals";
    case ParamType::per_type: return "real or one per type";
  }
  return "?";
}

ParamSpec ParamSpec::real(std::string name, std::optional<double> def, std::string doc) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = ParamType::real;
  if (def) s.default_value = *def;
  s.doc = std::move(doc);
  return s;
}
ParamSpec ParamSpec::integer(std::string name, std::optional<std::int64_t> def, std::string doc) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = ParamType::integer;
  if (def) s.default_value = *def;
  s.doc = std::move(doc);
  return s;
}
ParamSpec ParamSpec::boolean(std::string name, bool def, std::string doc) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = ParamType::boolean;
  s.default_value = def;
  s.doc = std::move(doc);
  return s;
}
ParamSpec ParamSpec::string(std::string name, std::optional<std::string> def, std::string doc) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = ParamType::string;
  if (def) s.default_value = *def;
  s.doc = std::move(doc);
  return s;
}
ParamSpec ParamSpec::strings(std::string name, std::vector<std::string> def, std::string doc) {
  ParamSpec s;
  s.name = std::move(name);
  s.type = ParamType::string_list;
  s.default_value = std::move(def);
  s.doc = std::move(doc);
  return s;
}

namespace {
std::string number(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}
std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}
}  // namespace

std::string ParamSpec::expectation() const {
  std::string e;
  switch (type) {
    case ParamType::real: e = "a real number"; break;
    case ParamType::integer: e = "an integer"; break;
    case ParamType::boolean: e = "true or false"; break;
    // A fixed set of words is described by the set alone ("one of: float, double").
    case ParamType::string: e = choices.empty() ? "a string" : ""; break;
    case ParamType::string_list: e = "a list of strings"; break;
    case ParamType::real_list: e = "a list of real numbers"; break;
    case ParamType::per_type: e = "a real number, or a list of them (one per particle type)"; break;
  }
  if (min && max) e += std::string(" in ") + (min_exclusive ? "(" : "[") + number(*min) + ", " + number(*max) + "]";
  else if (min) e += (min_exclusive ? " > " : " >= ") + number(*min);
  else if (max) e += " <= " + number(*max);
  if (!choices.empty()) e += type == ParamType::string ? "one of: " + join(choices) : " (each one of: " + join(choices) + ")";
  return e;
}

namespace {
bool in_range(const ParamSpec& s, double v) {
  if (s.min && (s.min_exclusive ? !(v > *s.min) : !(v >= *s.min))) return false;
  if (s.max && !(v <= *s.max)) return false;
  return true;
}
bool allowed(const ParamSpec& s, const std::string& v) {
  if (s.choices.empty()) return true;
  for (auto& c : s.choices)
    if (c == v) return true;
  return false;
}
}  // namespace

std::string check_param(const ParamSpec& s, const ParamValue& v) {
  bool ok = false;
  switch (s.type) {
    case ParamType::real:
      ok = std::holds_alternative<double>(v) && in_range(s, std::get<double>(v));
      break;
    case ParamType::integer:
      ok = std::holds_alternative<std::int64_t>(v) && in_range(s, double(std::get<std::int64_t>(v)));
      break;
    case ParamType::boolean: ok = std::holds_alternative<bool>(v); break;
    case ParamType::string:
      ok = std::holds_alternative<std::string>(v) && allowed(s, std::get<std::string>(v));
      break;
    case ParamType::string_list:
      ok = std::holds_alternative<std::vector<std::string>>(v);
      if (ok)
        for (auto& x : std::get<std::vector<std::string>>(v)) ok = ok && allowed(s, x);
      break;
    case ParamType::real_list:
    case ParamType::per_type:
      ok = std::holds_alternative<std::vector<double>>(v);
      if (ok)
        for (double x : std::get<std::vector<double>>(v)) ok = ok && in_range(s, x);
      break;
  }
  return ok ? std::string() : s.expectation();
}

std::string format_value(const ParamValue& v) {
  struct V {
    std::string operator()(double d) const { return number(d); }
    std::string operator()(std::int64_t i) const { return std::to_string(i); }
    std::string operator()(bool b) const { return b ? "true" : "false"; }
    std::string operator()(const std::string& s) const { return s; }
    std::string operator()(const std::vector<std::string>& l) const { return "[" + join(l) + "]"; }
    std::string operator()(const std::vector<double>& l) const {
      std::vector<std::string> s;
      for (double d : l) s.push_back(number(d));
      return "[" + join(s) + "]";
    }
  };
  return std::visit(V{}, v);
}

std::string format_value(const ParamSpec& spec, const ParamValue& v) {
  if (spec.type == ParamType::per_type)
    if (auto* l = std::get_if<std::vector<double>>(&v); l && l->size() == 1) return number(l->front());
  return format_value(v);
}

const ParamValue& ParamValues::get(const std::string& key) const {
  auto it = values_.find(key);
  if (it == values_.end()) throw std::logic_error("parameter '" + key + "' was not declared");
  return it->second;
}
double ParamValues::real(const std::string& key) const { return std::get<double>(get(key)); }
std::int64_t ParamValues::integer(const std::string& key) const { return std::get<std::int64_t>(get(key)); }
bool ParamValues::boolean(const std::string& key) const { return std::get<bool>(get(key)); }
const std::string& ParamValues::string(const std::string& key) const { return std::get<std::string>(get(key)); }
const std::vector<std::string>& ParamValues::strings(const std::string& key) const {
  return std::get<std::vector<std::string>>(get(key));
}
std::vector<double> ParamValues::reals(const std::string& key) const {
  const ParamValue& v = get(key);
  if (auto* d = std::get_if<double>(&v)) return {*d};
  return std::get<std::vector<double>>(v);
}

ParamValues ParamValues::defaults(const std::vector<ParamSpec>& specs) {
  ParamValues v;
  for (auto& s : specs)
    if (s.default_value) v.set(s.name, *s.default_value);
  return v;
}

}  // namespace ff
