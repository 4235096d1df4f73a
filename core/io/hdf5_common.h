// What the HDF5 files of core/io share (the H5MD writer and reader, the checkpoint file):
// silencing HDF5's own error printing, closing handles at scope exit, and the HDF5 types of
// flipflow's field types. Internal to core/io's .cpp files (it includes hdf5.h).
#pragma once
#include <hdf5.h>
#include <sys/statvfs.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>

#include "core/base/types.h"

namespace ff::hdf5 {

// The bytes free to this user on the disk holding `file` (its folder's); the largest value when it
// cannot tell. The writers check it before a frame or a checkpoint: HDF5 may leave a file it ran
// out of space in mid-write unreadable, and crash at exit trying to close it.
inline std::uint64_t free_bytes(const std::string& file) {
  const std::string folder = std::filesystem::path(file).parent_path().string();
  struct statvfs vfs = {};
  if (::statvfs(folder.empty() ? "." : folder.c_str(), &vfs) != 0) return std::numeric_limits<std::uint64_t>::max();
  return std::uint64_t(vfs.f_bavail) * std::uint64_t(vfs.f_frsize);
}

// HDF5 prints its error stack by default; core/io reports through exceptions instead.
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

// Closes an HDF5 handle at scope exit; movable, so a handle can outlive the scope that opened it
// (the H5MD writer keeps its file, groups and datasets in members).
struct Handle {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Handle() = default;
  Handle(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  Handle(Handle&& o) noexcept : id(o.id), close(o.close) { o.id = -1; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id = o.id;
      close = o.close;
      o.id = -1;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }
  hid_t get() const { return id; }
  hid_t release() {
    const hid_t i = id;
    id = -1;
    return i;
  }
  void reset() {
    if (id >= 0 && close) close(id);
    id = -1;
  }
};

// HDF5's own description of the error just raised (the innermost three entries of its stack).
inline std::string error_text() {
  std::string s;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_DOWNWARD,
      [](unsigned n, const H5E_error2_t* e, void* out) -> herr_t {
        auto& text = *static_cast<std::string*>(out);
        if (n < 3 && e->desc && *e->desc) text += (text.empty() ? "" : "; ") + std::string(e->desc);
        return 0;
      },
      &s);
  return s.empty() ? "unknown HDF5 error" : s;
}

// The little-endian file type and the native memory type of a field type.
inline hid_t file_type(DType t) {
  switch (t) {
    case DType::f32: return H5T_IEEE_F32LE;
    case DType::f64: return H5T_IEEE_F64LE;
    case DType::i32: return H5T_STD_I32LE;
    case DType::u32: return H5T_STD_U32LE;
    case DType::i64: return H5T_STD_I64LE;
    case DType::u64: return H5T_STD_U64LE;
    case DType::u8: return H5T_STD_U8LE;
  }
  return -1;
}
inline hid_t memory_type(DType t) {
  switch (t) {
    case DType::f32: return H5T_NATIVE_FLOAT;
    case DType::f64: return H5T_NATIVE_DOUBLE;
    case DType::i32: return H5T_NATIVE_INT32;
    case DType::u32: return H5T_NATIVE_UINT32;
    case DType::i64: return H5T_NATIVE_INT64;
    case DType::u64: return H5T_NATIVE_UINT64;
    case DType::u8: return H5T_NATIVE_UINT8;
  }
  return -1;
}

}  // namespace ff::hdf5
