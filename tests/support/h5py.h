// Output files are checked with h5py through /usr/bin/python3 (Debian's python3-h5py). A
// machine without it (a GPU node running a bundle) skips those checks with a visible warning.
#pragma once
#include <catch2/catch.hpp>
#include <cstdlib>

namespace ff::test {

inline bool have_h5py() {
  static const bool ok = std::system("/usr/bin/python3 -c 'import h5py, numpy' >/dev/null 2>&1") == 0;
  return ok;
}

// True when h5py is there; otherwise WARNs "SKIPPED ..." so the skip shows in the log.
inline bool can_check_h5md(const char* what) {
  if (have_h5py()) return true;
  WARN(std::string("SKIPPED (no h5py in /usr/bin/python3): ") + what);
  return false;
}

}  // namespace ff::test
