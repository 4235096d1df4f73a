// The particle types a stage's `types: [names]` parameter selects, as a bit mask over the indices
// of system.types (State::species): trap.harmonic's trapped particles, observe.mean's averaged
// ones. nvcc-clean.
#pragma once
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "core/base/error.h"
#include "core/stage/state.h"

namespace ff {

// Bit t set for each name, t its index in `s.species`; an unknown name, or one beyond the first
// `max_types` types, is an InputError that begins with `who` and lists the system's types.
inline std::uint64_t type_mask(const State& s, const std::vector<std::string>& names, const std::string& who,
                               int max_types = 64) {
  std::uint64_t mask = 0;
  for (const std::string& name : names) {
    const auto it = std::find(s.species.begin(), s.species.end(), name);
    if (it == s.species.end()) {
      std::string known;
      for (const std::string& k : s.species) known += (known.empty() ? "" : ", ") + k;
      throw InputError(who + ": types names `" + name + "`, which is not one of system.types (" +
                       (known.empty() ? std::string("the system has one unnamed type; drop types") : known) + ")");
    }
    const auto t = int(it - s.species.begin());
    if (t >= max_types)
      throw InputError(who + ": types: `" + name + "` is type " + std::to_string(t) + "; only the first " +
                       std::to_string(max_types) + " types can be chosen");
    mask |= std::uint64_t(1) << t;
  }
  return mask;
}

}  // namespace ff
