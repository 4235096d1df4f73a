// Did-you-mean suggestions for a misspelt name: the pipeline loader's messages (keys, stage
// ids, sections) and the registry's (an unknown stage).
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace ff {

// Optimal-string-alignment distance (a swap of neighbours costs one).
std::size_t edit_distance(const std::string& a, const std::string& b);
// "; did you mean 'x'?" when one known word is a plausible typo of `word`, or the same name in
// another case, or (for dotted names) has the same last part; else "".
std::string suggestion(const std::string& word, const std::vector<std::string>& known);

}  // namespace ff
