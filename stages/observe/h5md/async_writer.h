// An H5mdWriter driven by one writer thread through a bounded queue, so the next steps compute
// while HDF5 writes. At most `depth` frames wait for the writer (queued or being written), plus
// the one being filled; their buffers are recycled, so steady state allocates nothing.
#pragma once
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "core/io/h5md_writer.h"
#include "stages/observe/h5md/frame.h"

namespace ff::observe {

class AsyncFrameWriter {
 public:
  AsyncFrameWriter(std::unique_ptr<H5mdWriter> writer, std::size_t depth);
  // Writes what is queued, then closes as not completed (keeps the .partial).
  ~AsyncFrameWriter();
  AsyncFrameWriter(const AsyncFrameWriter&) = delete;
  AsyncFrameWriter& operator=(const AsyncFrameWriter&) = delete;

  // A buffer to fill, once fewer than `depth` frames are pending. Rethrows a failed write.
  Frame take();
  void submit(Frame frame);
  // Block until every submitted frame is written and flushed. Rethrows a failed write.
  void drain();
  // Write what is queued, stop the thread and close the file (renamed when completed and no
  // write failed). Rethrows a failed write after closing.
  void close(bool completed);

 private:
  void loop();
  void rethrow_locked() const;

  std::unique_ptr<H5mdWriter> writer_;
  std::FILE* const messages_;  // the writer's (H5mdWriter::messages), kept for the destructor
  const std::size_t depth_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Frame> queue_;
  std::vector<Frame> spare_;
  std::size_t pending_ = 0;  // submitted and not yet written
  bool stopping_ = false;
  std::exception_ptr error_;
  std::thread thread_;
};

}  // namespace ff::observe
