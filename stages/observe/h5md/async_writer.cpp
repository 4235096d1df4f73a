#include "stages/observe/h5md/async_writer.h"

#include <cstdio>

namespace ff::observe {

AsyncFrameWriter::AsyncFrameWriter(std::unique_ptr<H5mdWriter> writer, std::size_t depth)
    : writer_(std::move(writer)), messages_(writer_->messages()), depth_(depth < 1 ? 1 : depth) {
  thread_ = std::thread([this] { loop(); });
}

AsyncFrameWriter::~AsyncFrameWriter() {
  if (!thread_.joinable()) return;
  try {
    close(false);
  } catch (const std::exception& e) {
    std::fprintf(messages_, "flipflow: %s\n", e.what());
  }
}

void AsyncFrameWriter::rethrow_locked() const {
  if (error_) std::rethrow_exception(error_);
}

Frame AsyncFrameWriter::take() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return pending_ < depth_ || error_; });
  rethrow_locked();
  if (spare_.empty()) return Frame{};
  Frame f = std::move(spare_.back());
  spare_.pop_back();
  return f;
}

void AsyncFrameWriter::submit(Frame frame) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rethrow_locked();
    queue_.push_back(std::move(frame));
    ++pending_;
  }
  changed_.notify_all();
}

void AsyncFrameWriter::drain() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return pending_ == 0 || error_; });
  rethrow_locked();
}

void AsyncFrameWriter::loop() {
  for (;;) {
    Frame f;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping, and everything is written
      f = std::move(queue_.front());
      queue_.pop_front();
    }
    std::exception_ptr failed;
    try {
      write_frame(*writer_, f);
    } catch (...) {
      failed = std::current_exception();
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (failed) {  // drop the rest: the file is suspect; callers see the error
        error_ = failed;
        // Their device copies may still be landing in the pinned buffers freed here.
        for (Frame& q : queue_) {
          try {
            q.ready.wait();
          } catch (...) {  // (the run fails with the write's error)
          }
        }
        queue_.clear();
        pending_ = 0;
      } else {
        spare_.push_back(std::move(f));
        --pending_;
      }
    }
    changed_.notify_all();
    if (failed) return;
  }
}

void AsyncFrameWriter::close(bool completed) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
  writer_->close(completed && !error_);
  if (error_) std::rethrow_exception(error_);
}

}  // namespace ff::observe
