// Small text helpers the pipeline loader and the `pipeline` tool share.
#pragma once
#include <string>

namespace ff {

// `s` without the spaces and tabs around it ("--set 'run.steps = 100'", "--grid 'v0=1, 2'").
inline std::string trimmed(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

}  // namespace ff
