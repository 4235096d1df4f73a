// h5hash: the SHA-256 of every dataset of HDF5 files, for comparing two runs' outputs dataset by
// dataset where h5py and the HDF5 command-line tools are missing (a GPU node running a bundle).
//
//   h5hash [--all] FILE.h5...
//
// One line per dataset, sorted by path: `<sha256>  <path>  <shape> <type>`, the hash taken over
// the dataset's values in the machine's native layout (what H5Dread gives), so two files whose
// datasets hold the same values in the same shape hash alike whatever their chunking or
// compression. /parameters and /h5md (what produced the run, when, the resume history) are left
// out unless --all: they differ between a run and its continuation by design.
// Exit 0; 2 when a file cannot be opened or read.
#include <hdf5.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

namespace {

// SHA-256 (FIPS 180-4).
class Sha256 {
 public:
  void add(const unsigned char* p, std::size_t n) {
    bits_ += std::uint64_t(n) * 8;
    while (n) {
      const std::size_t take = std::min<std::size_t>(n, 64 - used_);
      std::memcpy(buf_ + used_, p, take);
      used_ += take;
      p += take;
      n -= take;
      if (used_ == 64) {
        block(buf_);
        used_ = 0;
      }
    }
  }
  std::string hex() {
    const std::uint64_t bits = bits_;
    const unsigned char one = 0x80, zero = 0;
    add(&one, 1);
    while (used_ != 56) add(&zero, 1);
    unsigned char len[8];
    for (int k = 0; k < 8; ++k) len[k] = static_cast<unsigned char>(bits >> (56 - 8 * k));
    add(len, 8);
    char out[65];
    for (int k = 0; k < 8; ++k) std::snprintf(out + 8 * k, 9, "%08x", h_[k]);
    return std::string(out, 64);
  }

 private:
  static std::uint32_t rotr(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }
  void block(const unsigned char* b) {
    static const std::uint32_t k[64] = {
        0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
        0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
        0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
        0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
        0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
        0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
        0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
        0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};
    std::uint32_t w[64];
    for (int t = 0; t < 16; ++t)
      w[t] = std::uint32_t(b[4 * t]) << 24 | std::uint32_t(b[4 * t + 1]) << 16 | std::uint32_t(b[4 * t + 2]) << 8 |
             std::uint32_t(b[4 * t + 3]);
    for (int t = 16; t < 64; ++t) {
      const std::uint32_t s0 = rotr(w[t - 15], 7) ^ rotr(w[t - 15], 18) ^ (w[t - 15] >> 3);
      const std::uint32_t s1 = rotr(w[t - 2], 17) ^ rotr(w[t - 2], 19) ^ (w[t - 2] >> 10);
      w[t] = w[t - 16] + s0 + w[t - 7] + s1;
    }
    std::uint32_t a = h_[0], bb = h_[1], c = h_[2], d = h_[3], e = h_[4], f = h_[5], g = h_[6], h = h_[7];
    for (int t = 0; t < 64; ++t) {
      const std::uint32_t t1 = h + (rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25)) + ((e & f) ^ (~e & g)) + k[t] + w[t];
      const std::uint32_t t2 = (rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22)) + ((a & bb) ^ (a & c) ^ (bb & c));
      h = g;
      g = f;
      f = e;
      e = d + t1;
      d = c;
      c = bb;
      bb = a;
      a = t1 + t2;
    }
    h_[0] += a;
    h_[1] += bb;
    h_[2] += c;
    h_[3] += d;
    h_[4] += e;
    h_[5] += f;
    h_[6] += g;
    h_[7] += h;
  }

  std::uint32_t h_[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  unsigned char buf_[64];
  std::size_t used_ = 0;
  std::uint64_t bits_ = 0;
};

struct Visit {
  bool all = false;
  bool failed = false;
  std::map<std::string, std::string> lines;  // path -> "<hash>  <path>  <shape> <type>"
};

std::string type_name(hid_t t) {
  switch (H5Tget_class(t)) {
    case H5T_INTEGER: return (H5Tget_sign(t) == H5T_SGN_NONE ? "u" : "i") + std::to_string(8 * H5Tget_size(t));
    case H5T_FLOAT: return "f" + std::to_string(8 * H5Tget_size(t));
    case H5T_STRING: return "string";
    default: return "other" + std::to_string(8 * H5Tget_size(t));
  }
}

herr_t visit(hid_t root, const char* name, const H5L_info_t*, void* op) {
  auto& v = *static_cast<Visit*>(op);
  const std::string n = name;
  if (!v.all && (n.rfind("parameters", 0) == 0 || n.rfind("h5md", 0) == 0)) return 0;
  H5O_info_t info;
#if H5_VERSION_GE(1, 12, 0)
  if (H5Oget_info_by_name3(root, name, &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0) return 0;
#else
  if (H5Oget_info_by_name(root, name, &info, H5P_DEFAULT) < 0) return 0;
#endif
  if (info.type != H5O_TYPE_DATASET) return 0;
  const hid_t d = H5Dopen2(root, name, H5P_DEFAULT);
  if (d < 0) {
    v.failed = true;
    return 0;
  }
  const hid_t ft = H5Dget_type(d);
  const hid_t sp = H5Dget_space(d);
  const int rank = H5Sget_simple_extent_ndims(sp);
  std::vector<hsize_t> dims(std::size_t(rank > 0 ? rank : 0));
  if (rank > 0) H5Sget_simple_extent_dims(sp, dims.data(), nullptr);
  std::size_t count = 1;
  std::string shape;
  for (auto x : dims) {
    count *= std::size_t(x);
    shape += (shape.empty() ? "" : "x") + std::to_string(x);
  }
  if (shape.empty()) shape = "scalar";
  Sha256 h;
  // Variable-length strings are hashed by their text; everything else by its native bytes.
  const bool vlen = H5Tget_class(ft) == H5T_STRING && H5Tis_variable_str(ft) > 0;
  if (vlen) {
    const hid_t mt = H5Tcopy(H5T_C_S1);
    H5Tset_size(mt, H5T_VARIABLE);
    std::vector<char*> s(count);
    if (count && H5Dread(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, s.data()) < 0) v.failed = true;
    for (char* p : s)
      if (p) h.add(reinterpret_cast<const unsigned char*>(p), std::strlen(p) + 1);
    if (count) H5Dvlen_reclaim(mt, sp, H5P_DEFAULT, s.data());
    H5Tclose(mt);
  } else {
    const hid_t mt = H5Tget_native_type(ft, H5T_DIR_ASCEND);
    std::vector<unsigned char> bytes(count * H5Tget_size(mt));
    if (count && H5Dread(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data()) < 0) v.failed = true;
    h.add(bytes.data(), bytes.size());
    H5Tclose(mt);
  }
  v.lines[n] = h.hex() + "  /" + n + "  " + shape + " " + type_name(ft);
  H5Sclose(sp);
  H5Tclose(ft);
  H5Dclose(d);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  bool all = false;
  std::vector<std::string> files;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--all") all = true;
    else if (a == "-h" || a == "--help") {
      std::printf("usage: h5hash [--all] FILE.h5...\n  the SHA-256 of every dataset (not /parameters, /h5md "
                  "unless --all), one line each: <sha256>  <path>  <shape> <type>\n");
      return 0;
    } else files.push_back(a);
  }
  if (files.empty()) {
    std::fprintf(stderr, "h5hash: usage: h5hash [--all] FILE.h5...\n");
    return 2;
  }
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  int rc = 0;
  for (auto& file : files) {
    const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (f < 0) {
      std::fprintf(stderr, "h5hash: cannot open '%s' as an HDF5 file\n", file.c_str());
      rc = 2;
      continue;
    }
    Visit v;
    v.all = all;
    H5Lvisit(f, H5_INDEX_NAME, H5_ITER_INC, visit, &v);
    H5Fclose(f);
    if (files.size() > 1) std::printf("# %s\n", file.c_str());
    for (auto& kv : v.lines) std::printf("%s\n", kv.second.c_str());
    if (v.failed) {
      std::fprintf(stderr, "h5hash: some datasets of '%s' could not be read\n", file.c_str());
      rc = 2;
    }
  }
  return rc;
}
