// Reading H5MD outputs in the end-to-end tests (test_checkpoint, test_sweep): every dataset of a
// file outside /parameters and /h5md, a /parameters string, and a bit-for-bit comparison of two
// files. What produced a run (/parameters: the start time, a resumed run's history) is not its
// output, so it is left out of the comparison.
#pragma once
#include <catch2/catch.hpp>
#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace ff::test {

struct Dataset {
  std::vector<hsize_t> shape;
  std::vector<unsigned char> bytes;
  bool operator==(const Dataset& o) const { return shape == o.shape && bytes == o.bytes; }
};

namespace detail {
inline herr_t collect_dataset(hid_t root, const char* name, const H5L_info_t*, void* op) {
  auto& out = *static_cast<std::map<std::string, Dataset>*>(op);
  const std::string n = name;
  if (n.rfind("parameters", 0) == 0 || n.rfind("h5md", 0) == 0) return 0;
  hid_t obj = H5Oopen(root, name, H5P_DEFAULT);
  if (obj < 0) return -1;
  const bool is_dataset = H5Iget_type(obj) == H5I_DATASET;
  H5Oclose(obj);
  if (!is_dataset) return 0;
  hid_t d = H5Dopen2(root, name, H5P_DEFAULT);
  hid_t ft = H5Dget_type(d);
  hid_t mt = H5Tget_native_type(ft, H5T_DIR_ASCEND);
  hid_t sp = H5Dget_space(d);
  const int rank = H5Sget_simple_extent_ndims(sp);
  Dataset ds;
  ds.shape.resize(std::size_t(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(sp, ds.shape.data(), nullptr);
  std::size_t count = 1;
  for (auto x : ds.shape) count *= x;
  ds.bytes.resize(count * H5Tget_size(mt));
  if (count) H5Dread(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, ds.bytes.data());
  out[n] = std::move(ds);
  H5Sclose(sp);
  H5Tclose(mt);
  H5Tclose(ft);
  H5Dclose(d);
  return 0;
}
}  // namespace detail

// Every dataset of `file` outside /parameters and /h5md, by path (without the leading '/').
inline std::map<std::string, Dataset> datasets(const std::filesystem::path& file) {
  std::map<std::string, Dataset> out;
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(f >= 0);
  H5Lvisit(f, H5_INDEX_NAME, H5_ITER_INC, detail::collect_dataset, &out);
  H5Fclose(f);
  return out;
}

// A scalar string dataset at `dataset` (an H5MD file's /parameters/effective_pipeline, a
// checkpoint's pipeline/overrides, ...), or "" when it or a group above it is missing.
inline std::string text_dataset(const std::filesystem::path& file, const std::string& dataset) {
  hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return "";
  std::string out;
  bool exists = true;  // (H5Lexists needs every group above the last link to exist)
  for (std::size_t slash = dataset.find('/', 1); exists; slash = dataset.find('/', slash + 1)) {
    exists = H5Lexists(f, dataset.substr(0, slash).c_str(), H5P_DEFAULT) > 0;
    if (slash == std::string::npos) break;
  }
  if (exists) {
    hid_t d = H5Dopen2(f, dataset.c_str(), H5P_DEFAULT);
    hid_t t = H5Dget_type(d);
    out.assign(H5Tget_size(t), '\0');
    H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data());
    while (!out.empty() && out.back() == '\0') out.pop_back();
    H5Tclose(t);
    H5Dclose(d);
  }
  H5Fclose(f);
  return out;
}

// A scalar string dataset under /parameters (/parameters/effective_pipeline, ...), or "" when missing.
inline std::string parameter_text(const std::filesystem::path& file, const std::string& dataset) {
  return dataset.rfind("/parameters", 0) == 0 ? text_dataset(file, dataset) : "";
}

inline std::string file_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Where dataset `name` of two files first differs, or "" when its bytes are equal: the first
// differing frame of a time series (with its step, read from the sibling `step` in `series_of_a`),
// the entry within it and the count of differing frames. Catch would print the two byte vectors
// instead, which for a trajectory takes minutes and reads as a hang.
inline std::string first_difference(const std::string& name, const Dataset& a, const Dataset& b,
                                    const std::map<std::string, Dataset>& series_of_a) {
  if (a.bytes == b.bytes) return "";
  std::ostringstream os;
  if (a.bytes.size() != b.bytes.size() || a.shape.empty()) {
    os << a.bytes.size() << " bytes against " << b.bytes.size();
    return os.str();
  }
  const std::size_t frames = std::max<std::size_t>(a.shape[0], 1), row = a.bytes.size() / frames;
  std::size_t first = frames, differing = 0, entry_byte = 0;
  for (std::size_t f = 0; f < frames; ++f) {
    const auto x = a.bytes.begin() + std::ptrdiff_t(f * row), y = b.bytes.begin() + std::ptrdiff_t(f * row);
    const auto m = std::mismatch(x, x + std::ptrdiff_t(row), y);
    if (m.first == x + std::ptrdiff_t(row)) continue;
    ++differing;
    if (first == frames) {
      first = f;
      entry_byte = std::size_t(m.first - x);
    }
  }
  std::size_t entries = 1;
  for (std::size_t k = 1; k < a.shape.size(); ++k) entries *= a.shape[k];
  const std::size_t entry_bytes = entries ? std::max<std::size_t>(row / entries, 1) : 1;
  os << differing << " of " << frames << " frames differ; the first is frame " << first;
  const std::string step_name = name.substr(0, name.rfind('/') + 1) + "step";
  const auto steps = series_of_a.find(step_name);
  if (name.size() > 6 && name.compare(name.size() - 6, 6, "/value") == 0 && steps != series_of_a.end() &&
      steps->second.bytes.size() >= (first + 1) * sizeof(std::int64_t)) {
    std::int64_t step;
    std::memcpy(&step, steps->second.bytes.data() + first * sizeof(std::int64_t), sizeof step);
    os << " (step " << step << ")";
  }
  os << ", from its entry " << entry_byte / entry_bytes << " (byte " << entry_byte << " of " << row << ")";
  return os.str();
}

// Every dataset of both files equal, bit for bit; returns how many were compared.
inline std::size_t require_same_h5md(const std::filesystem::path& a, const std::filesystem::path& b) {
  INFO(a << " vs " << b);
  REQUIRE(std::filesystem::exists(a));
  REQUIRE(std::filesystem::exists(b));
  const auto da = datasets(a), db = datasets(b);
  std::vector<std::string> ka, kb;
  for (auto& kv : da) ka.push_back(kv.first);
  for (auto& kv : db) kb.push_back(kv.first);
  REQUIRE(ka == kb);
  for (auto& [name, d] : da) {
    INFO("dataset " << name);
    CHECK(d.shape == db.at(name).shape);
    CHECK(first_difference(name, d, db.at(name), da) == "");
  }
  return da.size();
}

// Whether two files hold the same datasets, bit for bit (a test keeps both when not).
inline bool same_h5md(const std::filesystem::path& a, const std::filesystem::path& b) {
  return std::filesystem::exists(a) && std::filesystem::exists(b) && datasets(a) == datasets(b);
}

}  // namespace ff::test
