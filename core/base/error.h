// The two kinds of failure a user sees. The `pipeline` command maps them to exit codes:
// InputError -> 2 (the input is wrong: fix the file or the flags), RunError -> 1 (the run failed).
#pragma once
#include <stdexcept>
#include <string>

namespace ff {

struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct RunError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace ff
