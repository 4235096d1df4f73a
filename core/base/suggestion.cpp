// Did-you-mean suggestions for misspelt names: see core/base/suggestion.h.
#include "core/base/suggestion.h"

#include <algorithm>

namespace ff {

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

}  // namespace ff
