#include "core/io/durable_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "core/base/error.h"

namespace ff::io {

void fsync_path(const std::string& path, bool directory) {
  const int fd = ::open(path.c_str(), directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

void write_text_durably(const std::string& path, const std::string& text, const std::string& who) {
  namespace fs = std::filesystem;
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw RunError(who + ": cannot write '" + tmp + "'");
    out.write(text.data(), std::streamsize(text.size()));
    out.close();
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw RunError(who + ": writing '" + tmp + "' failed (disk full?)");
    }
  }
  fsync_path(tmp, false);
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw RunError(who + ": cannot rename '" + tmp + "' to '" + path + "': " + ec.message());
  const std::string folder = fs::path(path).parent_path().string();
  fsync_path(folder.empty() ? "." : folder, true);
}

}  // namespace ff::io
