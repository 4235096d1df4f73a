// A stage's persistent state for a checkpoint: named byte blobs (Stage::save_state fills one,
// Stage::restore_state reads it back in a continued run). What a stage keeps outside the
// state's fields and needs to continue bit for bit goes here: observe.msd's reference
// positions, observe.gr's histogram, neighbors.verlet's "a list exists" flag. Fields are
// checkpointed by the core; a stage stores only what lives in its own members. nvcc-clean.
#pragma once
#include <cstdint>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace ff {

class StageState {
 public:
  using Bytes = std::vector<unsigned char>;

  void put_bytes(const std::string& name, Bytes b) { blobs_[name] = std::move(b); }
  // A trivially copyable value or a vector of them, stored as its bytes.
  template <class T>
  void put(const std::string& name, const T& v) {
    static_assert(std::is_trivially_copyable_v<T>, "StageState::put: store plain values or vectors of them");
    Bytes b(sizeof(T));
    std::memcpy(b.data(), &v, sizeof(T));
    blobs_[name] = std::move(b);
  }
  template <class T>
  void put(const std::string& name, const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>, "StageState::put: store plain values or vectors of them");
    Bytes b(v.size() * sizeof(T));
    if (!b.empty()) std::memcpy(b.data(), v.data(), b.size());
    blobs_[name] = std::move(b);
  }
  void put(const std::string& name, const std::string& s) { blobs_[name] = Bytes(s.begin(), s.end()); }

  bool has(const std::string& name) const { return blobs_.count(name) != 0; }
  const Bytes& bytes(const std::string& name) const {
    auto it = blobs_.find(name);
    if (it == blobs_.end()) throw std::runtime_error("the checkpoint has no stage state '" + name + "'");
    return it->second;
  }
  // The value stored by put<T>; std::runtime_error when missing or of another size.
  template <class T>
  T get(const std::string& name) const {
    const Bytes& b = bytes(name);
    if (b.size() != sizeof(T)) throw std::runtime_error("stage state '" + name + "' has the wrong size");
    T v;
    std::memcpy(&v, b.data(), sizeof(T));
    return v;
  }
  template <class T>
  std::vector<T> get_vector(const std::string& name) const {
    const Bytes& b = bytes(name);
    if (b.size() % sizeof(T)) throw std::runtime_error("stage state '" + name + "' has the wrong size");
    std::vector<T> v(b.size() / sizeof(T));
    if (!b.empty()) std::memcpy(v.data(), b.data(), b.size());
    return v;
  }
  std::string get_string(const std::string& name) const {
    const Bytes& b = bytes(name);
    return std::string(b.begin(), b.end());
  }

  const std::map<std::string, Bytes>& all() const { return blobs_; }
  bool empty() const { return blobs_.empty(); }

 private:
  std::map<std::string, Bytes> blobs_;
};

}  // namespace ff
