// The pipeline loader under bad input (issue 19, item 6): thousands of mutations of every shipped
// pipeline (pipelines/*.yaml): lines deleted, duplicated, swapped and re-indented; keys retyped;
// values replaced by wrong types, huge, negative and non-finite numbers, unicode and YAML
// oddities; the text truncated or spliced with stray bytes. Each goes through what `pipeline
// validate` does before it builds the state (parse, the plugin list, resolve against the
// registry), in process. What `pipeline validate` would answer must be exit 0 (valid) or exit 2
// (an InputError) whose message starts with the location "FILE:line:column: " or "--set ...",
// never another exception (exit 1: a crash in the loader), never a mutation that takes longer
// than a second (a hang). The generator is deterministic (a fixed seed and its own integer
// draws), so a failure names a mutation that reproduces; the report prints its text.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/input/pipeline_loader.h"
#include "core/run/builtin_stages.h"
#include "core/run/plugin_loader.h"
#include "support/cli.h"

namespace fs = std::filesystem;

namespace {

constexpr int kMutationsPerFile = 400;

// splitmix64: the same draws on every platform and standard library.
class Draws {
 public:
  explicit Draws(std::uint64_t seed) : s_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::size_t below(std::size_t n) { return n ? std::size_t(next() % n) : 0; }
  template <class T>
  const T& pick(const std::vector<T>& v) { return v[below(v.size())]; }

 private:
  std::uint64_t s_;
};

const std::vector<std::string> kValues = {
    "-1", "0", "-0", "1", "-2.5", "1e308", "-1e308", "1e400", "-1e400", "4.9e-324", ".nan", "NaN", "nan", ".inf",
    "-.inf", "inf", "99999999999999999999999", "18446744073709551616", "-9223372036854775809", "2147483648",
    "4294967296", "0x7fffffff", "0o17", "1_000", "1.5", "3", "true", "false", "yes", "null", "~", "\"\"", "''",
    "abc", "[]", "{}", "[1, 2, 3]", "[a, b]", "{a: 1}", "[[1]]", "\"é\"", "漢字", "\"\\u0000\"", "ü-Ω-∞", "\"\\t\"",
    "&anchor 1", "*nowhere", "!!binary aGVsbG8=", "!!str 3", "!!int abc", "!custom x", "{a: [", "[1, {", "'", "\"",
    "|", ">", "- x", "? x", "%YAML 1.2", "---", "...", "#", "@", "`", "\\", "&a [*a]", "<<: {a: 1}", "1e-400",
    "0.0000000000000000000001", "1e19", "-1e19", "9.3e18", "-0.0", "+1", "1.", ".5", "1e", "e5", "1,5", "1 2"};

const std::vector<std::string> kBytes = {"\xc3", "\xff", "\xe6\xbc", "\t", "\r", "\n", "\x01", "\x7f", "  ", ":",
                                         "- ", "{", "}", "[", "]", ",", "\"", "'", "#", "&", "*", "!", "|", ">",
                                         "%", "@", "\xef\xbb\xbf", "\xe2\x80\xa8", "é", "∞", "\x02"};

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string line;
  while (std::getline(in, line)) out.push_back(line);
  return out;
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string out;
  for (auto& l : lines) out += l + "\n";
  return out;
}

// Where keys ("name:") and values (after ": " up to , } ] # or the line's end) lie in the text.
struct Span {
  std::size_t begin, end;
};
std::vector<Span> spans(const std::string& text, const std::regex& re, int group) {
  std::vector<Span> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), re); it != std::sregex_iterator(); ++it)
    out.push_back({std::size_t(it->position(group)), std::size_t(it->position(group) + it->length(group))});
  return out;
}

std::string mutate_once(const std::string& text, Draws& d) {
  static const std::regex key_re(R"(([A-Za-z_][A-Za-z0-9_.#]*)\s*:)");
  static const std::regex value_re(R"(:[ ]+([^,}\]\n#][^,}\]\n#]*))");
  std::vector<std::string> lines = lines_of(text);
  const std::size_t n = lines.size();
  switch (d.below(9)) {
    case 0:  // delete a line
      if (n) lines.erase(lines.begin() + std::ptrdiff_t(d.below(n)));
      return join_lines(lines);
    case 1:  // duplicate a line (duplicated keys, repeated steps)
      if (n) {
        const std::size_t i = d.below(n);
        lines.insert(lines.begin() + std::ptrdiff_t(i), lines[i]);
      }
      return join_lines(lines);
    case 2:  // swap two lines
      if (n) std::swap(lines[d.below(n)], lines[d.below(n)]);
      return join_lines(lines);
    case 3: {  // re-indent a line
      if (!n) return text;
      std::string& l = lines[d.below(n)];
      if (d.below(2) && !l.empty() && l[0] == ' ') l.erase(0, 1 + d.below(std::min<std::size_t>(3, l.size())));
      else l.insert(0, std::string(1 + d.below(4), ' '));
      return join_lines(lines);
    }
    case 4: {  // retype a key: another key of the file, one letter changed, or a stray name
      const auto keys = spans(text, key_re, 1);
      if (keys.empty()) return text;
      const Span k = d.pick(keys);
      std::string name = text.substr(k.begin, k.end - k.begin);
      switch (d.below(4)) {
        case 0: {
          const Span o = d.pick(keys);
          name = text.substr(o.begin, o.end - o.begin);
          break;
        }
        case 1: name[d.below(name.size())] = char('a' + d.below(26)); break;
        case 2: name += d.pick(std::vector<std::string>{"s", "_", "é", ".x", "0"}); break;
        default: name = d.pick(std::vector<std::string>{"", "step", "run", "system", "stage", "after", "every", "id",
                                                         "plugins", "N", "dt", "seed", "ü", "1"});
      }
      return text.substr(0, k.begin) + name + text.substr(k.end);
    }
    case 5: {  // replace a value with a wrong type, an extreme number, unicode or YAML syntax
      const auto values = spans(text, value_re, 1);
      if (values.empty()) return text;
      const Span v = d.pick(values);
      return text.substr(0, v.begin) + d.pick(kValues) + text.substr(v.end);
    }
    case 6:  // truncate anywhere (also inside a multi-byte character)
      return text.substr(0, d.below(text.size() + 1));
    case 7: {  // splice stray bytes in
      const std::size_t at = d.below(text.size() + 1);
      return text.substr(0, at) + d.pick(kBytes) + text.substr(at);
    }
    default: {  // a number made huge, negative or non-finite where it stands
      static const std::regex number_re(R"([-+]?[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?)");
      const auto numbers = spans(text, number_re, 0);
      if (numbers.empty()) return text;
      const Span v = d.pick(numbers);
      return text.substr(0, v.begin) +
             d.pick(std::vector<std::string>{"-1", "1e300", "-1e300", ".nan", ".inf", "-.inf", "0",
                                             "123456789012345678901234567890", "-0.000001"}) +
             text.substr(v.end);
    }
  }
}

std::string mutate(const std::string& text, Draws& d) {
  std::string out = mutate_once(text, d);
  for (std::size_t extra = d.below(4) == 0 ? 1 + d.below(3) : 0; extra; --extra) out = mutate_once(out, d);
  return out;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST_CASE("pipeline validate's loader: every mutation of every shipped pipeline is valid or a located error",
          "[input][fuzz]") {
  // Every stage library and every model plugin, loaded once (a mutation's plugin list is still
  // checked name by name against the search path, as `pipeline validate` does).
  ff::Registry registry;
  ff::register_builtin_stages(registry);
  const auto path = ff::plugin_search_path();
  auto files = ff::find_stage_libraries(path);
  for (auto& f : ff::find_model_plugins(path)) files.push_back(f);
  ff::load_plugins(files, registry);

  std::vector<fs::path> pipelines;
  for (auto& e : fs::directory_iterator(ff::test::repo_file("pipelines")))
    if (e.path().extension() == ".yaml") pipelines.push_back(e.path());
  std::sort(pipelines.begin(), pipelines.end());
  REQUIRE(pipelines.size() >= 10);

  std::size_t valid = 0, located = 0, problems = 0, total = 0;
  std::string report;
  Draws d(19);
  const auto start = std::chrono::steady_clock::now();
  for (auto& file : pipelines) {
    const std::string name = "pipelines/" + file.filename().string();
    const std::string original = read_file(file);
    const std::regex location("^" + std::regex_replace(name, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                              R"(:[0-9]+:[0-9]+: |^--set )");
    for (int m = 0; m < kMutationsPerFile; ++m) {
      ++total;
      const std::string text = mutate(original, d);
      std::string problem;
      const auto t0 = std::chrono::steady_clock::now();
      try {
        auto doc = ff::PipelineDocument::parse_string(text, name);
        ff::find_plugins(doc.plugins(), path, [&doc](std::size_t i) { return doc.plugin_location(i); });
        doc.resolve(registry);
        ++valid;
      } catch (const ff::InputError& e) {
        if (std::regex_search(std::string(e.what()), location)) ++located;
        else problem = std::string("exit 2 without a location: ") + e.what();
      } catch (const std::exception& e) {
        problem = std::string("not an input error (exit 1): ") + typeid(e).name() + ": " + e.what();
      } catch (...) {
        problem = "an exception that is not a std::exception";
      }
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (problem.empty() && seconds > 1.0) problem = "took " + std::to_string(seconds) + " s (a hang?)";
      if (!problem.empty() && ++problems <= 8)
        report += "\n--- " + name + " mutation " + std::to_string(m) + ": " + problem + "\n" + text.substr(0, 1500);
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  INFO(total << " mutations of " << pipelines.size() << " files in " << seconds << " s: " << valid << " valid, "
             << located << " located errors, " << problems << " problems" << report);
  CHECK(problems == 0);
  CHECK(valid + located == total);
  // The mutations must reach the resolver, not only the YAML parser: some stay valid.
  CHECK(valid >= total / 50);
  CHECK(located >= total / 2);
  WARN(total << " mutations of " << pipelines.size() << " pipelines in " << seconds << " s: " << valid
             << " valid, " << located << " errors with a location");
}
