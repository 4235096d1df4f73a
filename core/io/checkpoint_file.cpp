#include "core/io/checkpoint_file.h"

#include <hdf5.h>

#include <cstring>
#include <filesystem>

#include "core/base/error.h"
#include "core/io/durable_file.h"
#include "core/io/hdf5_common.h"

namespace fs = std::filesystem;

namespace ff {

namespace {

using hdf5::QuietErrors;
using hdf5::Handle;
using hdf5::file_type;
using hdf5::memory_type;

constexpr const char* kFormat = "flipflow checkpoint 1";

bool dtype_of_file_type(hid_t t, DType& out) {
  const H5T_class_t c = H5Tget_class(t);
  const std::size_t size = H5Tget_size(t);
  if (c == H5T_FLOAT) {
    if (size == 4) out = DType::f32;
    else if (size == 8) out = DType::f64;
    else return false;
    return true;
  }
  if (c != H5T_INTEGER) return false;
  const bool is_signed = H5Tget_sign(t) == H5T_SGN_2;
  if (size == 1 && !is_signed) out = DType::u8;
  else if (size == 4) out = is_signed ? DType::i32 : DType::u32;
  else if (size == 8) out = is_signed ? DType::i64 : DType::u64;
  else return false;
  return true;
}

// FNV-1a over 64-bit words (bytes for the tail): fast enough for gigabytes, and it sees every bit.
struct Hasher {
  std::uint64_t h = 1469598103934665603ull;
  static constexpr std::uint64_t prime = 1099511628211ull;
  void bytes(const void* p, std::size_t n) {
    const unsigned char* c = static_cast<const unsigned char*>(p);
    std::size_t i = 0;
    for (; i + 8 <= n; i += 8) {
      std::uint64_t w;
      std::memcpy(&w, c + i, 8);
      h = (h ^ w) * prime;
    }
    for (; i < n; ++i) h = (h ^ c[i]) * prime;
  }
  void u64(std::uint64_t v) { bytes(&v, 8); }
};

}  // namespace

// ---- CheckpointData ---------------------------------------------------------------------

void CheckpointData::put_array(const std::string& path, DType dtype, std::vector<std::uint64_t> shape,
                               const void* data, std::size_t bytes) {
  CheckpointEntry e;
  e.dtype = dtype;
  e.shape = std::move(shape);
  e.bytes.resize(bytes);
  if (bytes) std::memcpy(e.bytes.data(), data, bytes);
  entries[path] = std::move(e);
}

void CheckpointData::put_text(const std::string& path, const std::string& text) {
  CheckpointEntry e;
  e.text = true;
  e.bytes.assign(text.begin(), text.end());
  entries[path] = std::move(e);
}

void CheckpointData::put_u64(const std::string& path, std::uint64_t v) { put_array(path, DType::u64, {1}, &v, 8); }
void CheckpointData::put_f64(const std::string& path, double v) { put_array(path, DType::f64, {1}, &v, 8); }

const CheckpointEntry& CheckpointData::at(const std::string& path) const {
  auto it = entries.find(path);
  if (it == entries.end()) throw InputError("the checkpoint has no entry '" + path + "' (written by another version?)");
  return it->second;
}

std::string CheckpointData::text(const std::string& path) const {
  const auto& e = at(path);
  return std::string(e.bytes.begin(), e.bytes.end());
}

std::uint64_t CheckpointData::u64(const std::string& path) const {
  const auto& e = at(path);
  if (e.text || e.dtype != DType::u64 || e.bytes.size() != 8) throw InputError("checkpoint entry '" + path + "' is not one u64");
  std::uint64_t v;
  std::memcpy(&v, e.bytes.data(), 8);
  return v;
}

double CheckpointData::f64(const std::string& path) const {
  const auto& e = at(path);
  if (e.text || e.dtype != DType::f64 || e.bytes.size() != 8) throw InputError("checkpoint entry '" + path + "' is not one f64");
  double v;
  std::memcpy(&v, e.bytes.data(), 8);
  return v;
}

std::vector<std::string> CheckpointData::children(const std::string& group) const {
  std::vector<std::string> out;
  const std::string prefix = group + "/";
  for (auto it = entries.lower_bound(prefix); it != entries.end() && it->first.compare(0, prefix.size(), prefix) == 0;
       ++it) {
    const std::string rest = it->first.substr(prefix.size());
    if (rest.find('/') == std::string::npos) out.push_back(rest);
  }
  return out;
}

std::uint64_t CheckpointData::checksum() const {
  Hasher h;
  for (auto& [path, e] : entries) {
    h.bytes(path.data(), path.size());
    h.u64(e.text ? 0xffu : std::uint64_t(e.dtype));
    h.u64(e.shape.size());
    for (auto d : e.shape) h.u64(d);
    h.u64(e.bytes.size());
    h.bytes(e.bytes.data(), e.bytes.size());
  }
  return h.h;
}

// ---- writing ----------------------------------------------------------------------------

void write_checkpoint_file(const std::string& path, const CheckpointData& data) {
  QuietErrors quiet;
  const fs::path target(path);
  const fs::path tmp = target.parent_path() / ("." + target.filename().string() + ".tmp");
  auto fail = [&](const std::string& what) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw RunError("writing the checkpoint '" + path + "' failed: " + what +
                   " (is the disk full? earlier checkpoints are kept)");
  };
  // Not begun without room for it (the data and ~1 KiB of metadata an entry, and 1 MiB): a file
  // that runs out of space mid-write may leave HDF5 unable to close it, and the process to crash
  // at exit (the failure audit of session 34).
  {
    std::uint64_t need = 1u << 20;
    for (auto& [name, e] : data.entries) need += e.bytes.size() + 1024;
    const std::uint64_t free = hdf5::free_bytes(path);
    if (free < need)
      throw RunError("writing the checkpoint '" + path + "' was not begun: its disk has " + std::to_string(free >> 10) +
                     " KiB free, less than the checkpoint needs (" + std::to_string(need >> 10) +
                     " KiB); earlier checkpoints are kept");
  }
  {
    Handle file(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (file.id < 0) fail("cannot create '" + tmp.string() + "'");
    Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
    H5Pset_create_intermediate_group(lcpl.id, 1);
    for (auto& [name, e] : data.entries) {
      if (e.text) {
        Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(t.id, std::max<std::size_t>(e.bytes.size(), 1));
        H5Tset_strpad(t.id, H5T_STR_NULLPAD);
        H5Tset_cset(t.id, H5T_CSET_UTF8);
        Handle space(H5Screate(H5S_SCALAR), H5Sclose);
        Handle d(H5Dcreate2(file.id, name.c_str(), t.id, space.id, lcpl.id, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
        std::string buf(e.bytes.begin(), e.bytes.end());
        if (buf.empty()) buf.push_back('\0');
        if (d.id < 0 || H5Dwrite(d.id, t.id, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0)
          fail("writing '" + name + "'");
        continue;
      }
      std::vector<hsize_t> dims(e.shape.begin(), e.shape.end());
      Handle space(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose);
      Handle d(H5Dcreate2(file.id, name.c_str(), file_type(e.dtype), space.id, lcpl.id, H5P_DEFAULT, H5P_DEFAULT),
               H5Dclose);
      if (d.id < 0) fail("creating '" + name + "'");
      if (!e.bytes.empty() && H5Dwrite(d.id, memory_type(e.dtype), H5S_ALL, H5S_ALL, H5P_DEFAULT, e.bytes.data()) < 0)
        fail("writing '" + name + "'");
    }
    auto attr = [&](const char* name, hid_t type, const void* v) {
      Handle space(H5Screate(H5S_SCALAR), H5Sclose);
      Handle a(H5Acreate2(file.id, name, type, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
      if (a.id < 0 || H5Awrite(a.id, type, v) < 0) fail(std::string("writing the attribute ") + name);
    };
    Handle st(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(st.id, std::strlen(kFormat));
    attr("format", st.id, kFormat);
    const std::uint64_t sum = data.checksum();
    attr("checksum", H5T_NATIVE_UINT64, &sum);
    const hid_t f = file.id;
    file.id = -1;
    if (H5Fclose(f) < 0) fail("closing '" + tmp.string() + "'");
  }
  io::fsync_path(tmp.string(), false);
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) fail("renaming '" + tmp.string() + "': " + ec.message());
  io::fsync_path(target.parent_path().empty() ? "." : target.parent_path().string(), true);
}

// ---- reading ----------------------------------------------------------------------------

namespace {

struct Visit {
  CheckpointData* data;
  std::string error;
};

// Links, not objects: H5Lvisit has one signature across HDF5 1.10 ... 1.14.
herr_t visit_link(hid_t root, const char* name, const H5L_info_t*, void* op) {
  auto& v = *static_cast<Visit*>(op);
  Handle obj(H5Oopen(root, name, H5P_DEFAULT), H5Oclose);
  if (obj.id < 0) {
    v.error = std::string("cannot open '") + name + "'";
    return -1;
  }
  if (H5Iget_type(obj.id) != H5I_DATASET) return 0;
  Handle d(H5Dopen2(root, name, H5P_DEFAULT), H5Dclose);
  if (d.id < 0) {
    v.error = std::string("cannot open '") + name + "'";
    return -1;
  }
  Handle t(H5Dget_type(d.id), H5Tclose);
  CheckpointEntry e;
  if (H5Tget_class(t.id) == H5T_STRING) {
    e.text = true;
    std::string buf(H5Tget_size(t.id), '\0');
    if (H5Dread(d.id, t.id, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0) {
      v.error = std::string("cannot read '") + name + "'";
      return -1;
    }
    while (!buf.empty() && buf.back() == '\0') buf.pop_back();
    e.bytes.assign(buf.begin(), buf.end());
  } else {
    if (!dtype_of_file_type(t.id, e.dtype)) {
      v.error = std::string("'") + name + "' has an element type flipflow does not write";
      return -1;
    }
    Handle space(H5Dget_space(d.id), H5Sclose);
    const int rank = H5Sget_simple_extent_ndims(space.id);
    std::vector<hsize_t> dims(std::size_t(std::max(rank, 0)));
    H5Sget_simple_extent_dims(space.id, dims.data(), nullptr);
    std::size_t count = 1;
    for (auto x : dims) {
      e.shape.push_back(x);
      count *= x;
    }
    e.bytes.resize(count * dtype_size(e.dtype));
    if (count && H5Dread(d.id, memory_type(e.dtype), H5S_ALL, H5S_ALL, H5P_DEFAULT, e.bytes.data()) < 0) {
      v.error = std::string("cannot read '") + name + "'";
      return -1;
    }
  }
  v.data->entries[name] = std::move(e);
  return 0;
}

}  // namespace

CheckpointData read_checkpoint_file(const std::string& path) {
  QuietErrors quiet;
  if (!fs::exists(path)) throw InputError("checkpoint '" + path + "' does not exist");
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (file.id < 0)
    throw InputError("checkpoint '" + path + "' cannot be read: truncated or not an HDF5 file");
  std::string format;
  std::uint64_t stored = 0;
  {
    Handle a(H5Aopen(file.id, "format", H5P_DEFAULT), H5Aclose);
    if (a.id >= 0) {
      Handle t(H5Aget_type(a.id), H5Tclose);
      format.assign(H5Tget_size(t.id), '\0');
      if (H5Aread(a.id, t.id, format.data()) < 0) format.clear();
      while (!format.empty() && format.back() == '\0') format.pop_back();
    }
  }
  if (format != kFormat)
    throw InputError("'" + path + "' is not a flipflow checkpoint (format attribute '" + format + "', expected '" +
                     kFormat + "')");
  {
    Handle a(H5Aopen(file.id, "checksum", H5P_DEFAULT), H5Aclose);
    if (a.id < 0 || H5Aread(a.id, H5T_NATIVE_UINT64, &stored) < 0)
      throw InputError("checkpoint '" + path + "' has no checksum: truncated or damaged");
  }
  CheckpointData data;
  Visit v{&data, ""};
  const herr_t rc = H5Lvisit(file.id, H5_INDEX_NAME, H5_ITER_INC, visit_link, &v);
  if (rc < 0)
    throw InputError("checkpoint '" + path + "' is damaged: " + (v.error.empty() ? "cannot list its contents" : v.error));
  const std::uint64_t sum = data.checksum();
  if (sum != stored)
    throw InputError("checkpoint '" + path + "' fails its checksum (stored " + std::to_string(stored) + ", computed " +
                     std::to_string(sum) + "): the file is corrupt");
  return data;
}

}  // namespace ff
