// Did-you-mean suggestions for misspelt names: see core/base/suggestion.h.
#include "core/base/suggestion.h"

#include <algorithm>
#include <cctype>

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

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string last_segment(const std::string& s) {
  const auto dot = s.rfind('.');
  return dot == std::string::npos ? s : s.substr(dot + 1);
}

// "'a'", "'a' or 'b'", "'a', 'b' or 'c'".
std::string quoted_alternatives(const std::vector<const std::string*>& words) {
  std::string s;
  for (std::size_t i = 0; i < words.size(); ++i)
    s += (i == 0 ? "" : i + 1 == words.size() ? " or " : ", ") + ("'" + *words[i] + "'");
  return s;
}

}  // namespace

// "; did you mean 'x'?" when one known word is a plausible typo of `word` (about one edit per
// three letters), else "". Suggesting a word that shares nothing with the input only confuses.
// Dotted names (stages, step ids) are also found by a different case ('Observe.MSD') and by their
// last part alone ('lj' for pair.lj), which no edit distance would allow.
std::string suggestion(const std::string& word, const std::vector<std::string>& known) {
  const std::string word_lower = lower(word);
  for (auto& k : known)
    if (lower(k) == word_lower) return "; did you mean '" + k + "'?";
  const std::size_t allowed = std::max<std::size_t>(1, word.size() / 3);
  const std::string* best = nullptr;
  std::size_t best_d = allowed + 1;
  for (auto& k : known) {
    std::size_t d = edit_distance(word, k);
    if (d < best_d) best_d = d, best = &k;
  }
  if (best) return "; did you mean '" + *best + "'?";
  const std::string tail = lower(last_segment(word));
  std::vector<const std::string*> same_tail;
  for (auto& k : known)
    if (k.find('.') != std::string::npos && lower(last_segment(k)) == tail) same_tail.push_back(&k);
  if (same_tail.empty() || same_tail.size() > 4) return "";
  return "; did you mean " + quoted_alternatives(same_tail) + "?";
}

}  // namespace ff
