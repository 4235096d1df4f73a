// `pipeline sweep`: grid arguments, combinations, folder names, the index CSV (sweep.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>
#include <utility>

#include "core/base/error.h"
#include "core/base/text.h"
#include "tools/pipeline/sweep.h"

namespace fs = std::filesystem;

namespace ff::cli::sweep {

Axis parse_grid(const std::string& arg) {
  const std::string where = "--grid " + arg;
  const auto eq = arg.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(where + ": expected KEY.PATH=V1,V2,... (keys as for --set, e.g. --grid run.seed=1,2,3)");
  Axis a;
  a.key = trimmed(arg.substr(0, eq));
  const std::string list = arg.substr(eq + 1);
  int depth = 0;
  char quote = 0;
  std::string cur;
  for (char c : list) {
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '\'' || c == '"') {
      quote = c;
    } else if (c == '[' || c == '{') {
      ++depth;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    } else if (c == ',' && depth == 0) {
      a.values.push_back(cur);
      cur.clear();
      continue;
    }
    cur += c;
  }
  a.values.push_back(cur);
  if (quote || depth) throw InputError(where + ": unbalanced quote or bracket in the values");
  // ('v0=1, 2' is two values, not '1' and ' 2'; '1' and '1.0' are one number)
  std::map<std::string, std::string> seen;  // a value's identity -> the value as given
  for (auto& v : a.values) {
    v = trimmed(v);
    if (v.empty()) throw InputError(where + ": an empty value (two commas in a row, or one at the end)");
    // A decimal number (not inf, nan or hex, which the loader refuses anyway) is its value; -0 is 0.
    char* end = nullptr;
    double x = std::strtod(v.c_str(), &end);
    const bool decimal = *end == 0 && v.find_first_not_of("0123456789+-.eE") == std::string::npos && std::isfinite(x);
    if (x == 0) x = 0;
    std::ostringstream number;
    number << std::setprecision(17) << x;
    const std::string identity = decimal ? "number " + number.str() : v;
    auto [it, fresh] = seen.emplace(identity, v);
    if (!fresh)
      throw InputError(where + ": the value '" + v + "' is given twice" +
                       (it->second == v ? std::string() : " ('" + it->second + "' is the same value)"));
  }
  return a;
}

std::vector<Run> combinations(const std::vector<Axis>& axes, int replicas) {
  std::vector<Run> runs;
  std::vector<std::size_t> at(axes.size(), 0);
  for (;;) {
    for (int r = 0; r < replicas; ++r) {
      Run run;
      for (std::size_t k = 0; k < axes.size(); ++k) run.values.push_back(axes[k].values[at[k]]);
      run.replica = r;
      runs.push_back(run);
    }
    // Odometer, last axis fastest.
    std::size_t k = axes.size();
    while (k > 0 && ++at[k - 1] == axes[k - 1].values.size()) at[--k] = 0;
    if (k == 0) break;
  }
  return runs;
}

namespace {
std::string safe(const std::string& s) {
  std::string o;
  for (char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '+' || c == '-' || c == '=';
    o += ok ? c : '_';
  }
  return o;
}

// FNV-1a, for names that collide after `safe`: stable across machines and builds.
std::string hash8(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  char buf[17];
  std::snprintf(buf, sizeof buf, "%08llx", static_cast<unsigned long long>(h & 0xffffffffull));
  return buf;
}
}  // namespace

void name_folders(const std::vector<Axis>& axes, std::vector<Run>& runs, bool with_seed) {
  std::vector<std::string> labels;
  std::map<std::string, int> uses;
  for (auto& a : axes) {
    const auto dot = a.key.rfind('.');
    labels.push_back(dot == std::string::npos ? a.key : a.key.substr(dot + 1));
    ++uses[labels.back()];
  }
  for (std::size_t i = 0; i < labels.size(); ++i)
    if (uses[labels[i]] > 1) labels[i] = axes[i].key;  // step.a.D and step.b.D: keep the whole key
  std::map<std::string, int> count;
  std::vector<std::string> raw(runs.size());
  for (std::size_t r = 0; r < runs.size(); ++r) {
    std::string name;
    for (std::size_t k = 0; k < axes.size(); ++k) {
      name += (k ? "_" : "") + labels[k] + "=" + runs[r].values[k];
      raw[r] += axes[k].key + "=" + runs[r].values[k] + "\n";
    }
    if (with_seed) name += std::string(name.empty() ? "" : "_") + "seed=" + std::to_string(runs[r].seed);
    raw[r] += "seed=" + std::to_string(runs[r].seed);
    if (name.empty()) name = "run";
    name = safe(name);
    if (name.size() > 200) name = name.substr(0, 190);
    runs[r].folder = name;
    ++count[name];
  }
  for (std::size_t r = 0; r < runs.size(); ++r)
    if (count[runs[r].folder] > 1 || runs[r].folder.size() >= 190) runs[r].folder += "-h" + hash8(raw[r]);
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string o = "\"";
  for (char c : s) {
    if (c == '"') o += '"';
    o += (c == '\n' || c == '\r') ? ' ' : c;
  }
  return o + "\"";
}

std::vector<std::string> csv_split(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cur += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cur += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

void write_index(const std::string& path, const std::vector<Axis>& axes, const std::vector<std::string>& shared_sets,
                 const std::vector<Run>& runs) {
  std::vector<std::pair<std::string, std::string>> shared;  // key -> value, in the order first given
  for (auto& set : shared_sets) {
    const auto eq = set.find('=');
    const std::string key = set.substr(0, eq), value = eq == std::string::npos ? "" : set.substr(eq + 1);
    auto same = std::find_if(shared.begin(), shared.end(), [&](auto& kv) { return kv.first == key; });
    if (same != shared.end())
      same->second = value;
    else
      shared.emplace_back(key, value);
  }
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw RunError("cannot write the sweep index '" + tmp + "'");
    out << "folder";
    for (auto& a : axes) out << "," << csv_field(a.key);
    for (auto& kv : shared) out << "," << csv_field(kv.first);
    out << ",replica,seed,status,exit_code,steps_per_s,particle_steps_per_s,wall_s,gpu,message\n";
    for (auto& r : runs) {
      out << csv_field(r.folder);
      for (auto& v : r.values) out << "," << csv_field(v);
      for (auto& kv : shared) out << "," << csv_field(kv.second);
      out << "," << r.replica << "," << r.seed << "," << r.status << ","
          << (r.exit_code >= 0 ? std::to_string(r.exit_code) : "") << ",";
      if (r.steps_per_s > 0)
        out << std::setprecision(6) << r.steps_per_s << "," << std::setprecision(6) << r.steps_per_s * double(r.N);
      else
        out << ",";
      out << ",";
      if (r.wall_s > 0) out << std::fixed << std::setprecision(3) << r.wall_s << std::defaultfloat;
      out << "," << csv_field(r.gpu) << "," << csv_field(r.message) << "\n";
    }
    out.flush();
    if (!out) throw RunError("cannot write the sweep index '" + tmp + "' (disk full?)");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw RunError("cannot rename '" + tmp + "' to '" + path + "': " + ec.message());
}

std::map<std::string, std::map<std::string, std::string>> read_index(const std::string& path) {
  std::map<std::string, std::map<std::string, std::string>> rows;
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return rows;
  const auto header = csv_split(line);
  while (std::getline(in, line)) {
    const auto f = csv_split(line);
    if (f.size() != header.size() || f.empty()) continue;  // a torn line cannot happen (rename), but be safe
    auto& row = rows[f[0]];
    for (std::size_t i = 0; i < f.size(); ++i) row[header[i]] = f[i];
  }
  return rows;
}

}  // namespace ff::cli::sweep
