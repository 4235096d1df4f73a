// The checkpoint file: named arrays and texts in one HDF5 file, with a checksum over all of
// them. What goes in it (fields, clock, Δt controller, stage states, the pipeline) is decided by
// core/run/checkpoint.h; this file only stores and verifies. No HDF5 types here (the core links
// HDF5 privately).
//
// Layout: every entry is a dataset at its path ("fields/position", "clock/step", "pipeline/
// effective"): arrays with their element type and shape, texts as one fixed-length UTF-8
// string. The root holds the attributes `format` ("flipflow checkpoint 1") and `checksum`
// (64-bit, over every entry's path, kind, shape and bytes in path order).
//
// Written to a temporary name in the same directory, flushed to disk (fsync) and renamed, so a
// reader sees either the previous set of checkpoints or the complete new file, never half of
// one.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/base/types.h"

namespace ff {

struct CheckpointEntry {
  bool text = false;                   // a string (bytes hold its characters)
  DType dtype = DType::u8;             // arrays: the element type
  std::vector<std::uint64_t> shape;    // arrays: dimensions (one for a flat array)
  std::vector<unsigned char> bytes;
};

class CheckpointData {
 public:
  std::map<std::string, CheckpointEntry> entries;

  void put_array(const std::string& path, DType dtype, std::vector<std::uint64_t> shape, const void* data,
                 std::size_t bytes);
  void put_text(const std::string& path, const std::string& text);
  void put_u64(const std::string& path, std::uint64_t v);
  void put_f64(const std::string& path, double v);

  bool has(const std::string& path) const { return entries.count(path) != 0; }
  const CheckpointEntry& at(const std::string& path) const;  // InputError naming the path when missing
  std::string text(const std::string& path) const;
  std::uint64_t u64(const std::string& path) const;
  double f64(const std::string& path) const;
  // Entries directly below `group` ("fields" -> "position", ...), in order; no deeper ones.
  std::vector<std::string> children(const std::string& group) const;

  // The 64-bit checksum of all entries (what the file stores and the reader recomputes).
  std::uint64_t checksum() const;
};

// Writes `data` to `path` atomically (temporary file, fsync, rename). RunError on failure; the
// temporary file is removed and an existing `path` is left as it was.
void write_checkpoint_file(const std::string& path, const CheckpointData& data);

// Reads and verifies a checkpoint file. InputError (naming the file) when it cannot be opened
// (missing, truncated, not HDF5), is not a flipflow checkpoint, or its checksum does not match.
CheckpointData read_checkpoint_file(const std::string& path);

}  // namespace ff
