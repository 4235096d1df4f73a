// The two kinds of failure a user sees. The `pipeline` command maps them to exit codes:
// InputError -> 2 (the input is wrong: fix the file or the flags), RunError -> 1 (the run failed).
#pragma once
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ff {

struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct RunError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Several input errors found in one reading, so that a file with three mistakes is fixed in one
// go, not three. what() is the messages one per line; `pipeline` prints each as its own error.
struct InputErrors : InputError {
  explicit InputErrors(std::vector<std::string> all) : InputError(joined(all)), messages(std::move(all)) {}
  std::vector<std::string> messages;

 private:
  static std::string joined(const std::vector<std::string>& all) {
    std::string text;
    for (auto& m : all) text += (text.empty() ? "" : "\n") + m;
    return text;
  }
};

// Each message of an InputError: the several of an InputErrors, else its one.
inline std::vector<std::string> messages_of(const InputError& e) {
  if (auto* several = dynamic_cast<const InputErrors*>(&e)) return several->messages;
  return {e.what()};
}

// The InputErrors of reads that do not depend on each other, collected so that a reader can go
// on past the first: attempt() each read, then raise() what they threw.
class InputErrorList {
 public:
  // Runs `read`; an InputError it throws is kept (each message of an InputErrors), not thrown.
  // Returns whether `read` finished.
  template <class Read>
  bool attempt(Read&& read) {
    try {
      read();
      return true;
    } catch (const InputErrors& e) {
      for (auto& m : e.messages) add(m);
    } catch (const InputError& e) {
      add(e.what());
    }
    return false;
  }
  bool empty() const { return messages_.empty(); }
  // Throws what was collected: one error as an InputError, several as InputErrors. Nothing when
  // none was.
  void raise() const {
    if (messages_.size() == 1) throw InputError(messages_[0]);
    if (!messages_.empty()) throw InputErrors(messages_);
  }

 private:
  void add(const std::string& m) {
    for (auto& have : messages_)
      if (have == m) return;  // one node reached by two reads
    messages_.push_back(m);
  }
  std::vector<std::string> messages_;
};

}  // namespace ff
