// The yaml-free half of the pipeline loader: the words of its messages (lists, key paths,
// did-you-mean suggestions, located errors) and the scalar grammar of parameter values.
// Internal to the loader (core/pipeline_*.cpp); no yaml-cpp here.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/base/suggestion.h"
#include "core/stage/params.h"
#include "core/input/pipeline_spec.h"

namespace ff::pipeline_detail {

// ---- words for messages -------------------------------------------------------------------

std::string join(const std::vector<std::string>& v);  // "a, b, c"
bool one_of(const std::string& s, const std::vector<std::string>& v);

using ff::edit_distance;  // (core/base/suggestion.h: the registry suggests names too)
using ff::suggestion;

// Key paths: child("run", "dt") = "run.dt", index("step", 2) = "step[2]".
std::string child(const std::string& path, const std::string& key);
std::string index(const std::string& path, std::size_t i);

// Throws InputError "WHERE: PATH: what" ("WHERE: what" when path is empty).
[[noreturn]] void fail(const Location& at, const std::string& path, const std::string& what);

// ---- scalars ------------------------------------------------------------------------------

bool is_number(const std::string& s);  // non-empty, decimal digits only
std::optional<double> to_real(std::string s);
std::optional<std::int64_t> to_integer(std::string s);
std::optional<bool> to_boolean(const std::string& s);
// A number written as a whole number that to_integer refuses only for its size ("1e20").
bool is_whole_number_out_of_range(const std::string& s);
// yes/no/on/off (YAML 1.1 booleans, plain strings in YAML 1.2): what the user meant, else nullopt.
std::optional<bool> yaml11_boolean(const std::string& s);
// "N:4096" -> "N: 4096" when `s` looks like a key and a value joined by ':' without a space.
std::optional<std::string> with_space_after_colon(const std::string& s);
// A scalar read as `type` (real, integer, boolean, string); nullopt when it is not one.
std::optional<ParamValue> to_scalar_value(ParamType type, const std::string& s);

}  // namespace ff::pipeline_detail
