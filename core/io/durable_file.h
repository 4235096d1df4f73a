// Files that survive the process being killed (kill -9, out of memory) mid-write: written under a
// temporary name beside their target, flushed to disk (fsync) and renamed over it, so a reader
// sees the previous version or the new one, never a truncated file.
#pragma once
#include <string>

namespace ff::io {

// fsync of a file or (directory = true) of a folder, so a rename in it is on the disk too.
void fsync_path(const std::string& path, bool directory);

// Replaces `path` with `text` as above. RunError naming `who` and the file on failure; the
// previous file, if any, is left as it was.
void write_text_durably(const std::string& path, const std::string& text, const std::string& who);

}  // namespace ff::io
