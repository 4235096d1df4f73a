#include "core/run/cuda/ghost_traffic.h"

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/device_buffer.h"
#include "core/physics/box.h"

namespace ff {

namespace {

constexpr int kThreads = 256;

unsigned blocks_for(std::size_t n) { return unsigned((n + kThreads - 1) / kThreads); }

// Whole records are copied as 32-bit words when every entry, record and offset allows it (the
// positions, images and ids: 4- and 8-byte components), else byte by byte.
template <class W>
__global__ void pack_kernel(const W* __restrict__ field, const std::uint32_t* __restrict__ idx, std::size_t n,
                            std::size_t words, W* __restrict__ out, std::size_t record_words, std::size_t offset_words) {
  const std::size_t t = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (t >= n * words) return;
  const std::size_t k = t / words, w = t % words;
  out[k * record_words + offset_words + w] = field[std::size_t(idx[k]) * words + w];
}

template <class W>
__global__ void unpack_kernel(W* __restrict__ field, const std::uint32_t* __restrict__ idx, std::size_t n,
                              std::size_t words, const W* __restrict__ in, std::size_t record_words,
                              std::size_t offset_words) {
  const std::size_t t = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (t >= n * words) return;
  const std::size_t k = t / words, w = t % words;
  field[std::size_t(idx[k]) * words + w] = in[k * record_words + offset_words + w];
}

// Domain.cpp's moved_beyond on the device: the same operations in the same precision (this file
// is compiled with -fmad=false, core/CMakeLists.txt), so the same decisions.
template <class R>
__global__ void moved_kernel(const R* __restrict__ x, const R* __restrict__ x0, std::size_t owned, int dim,
                             PeriodicBox<R> box, R limit2, std::uint32_t* flag) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= owned) return;
  R d2 = 0;
  for (int k = 0; k < dim; ++k) {
    const R d = box.min_image(x[i * dim + k] - x0[i * dim + k], k);
    d2 += d * d;
  }
  if (d2 > limit2) *flag = 1u;  // every writer stores the same value
}

bool word_aligned(std::size_t entry, std::size_t record, std::size_t offset) {
  return entry % 4 == 0 && record % 4 == 0 && offset % 4 == 0;
}

void grow(std::unique_ptr<DeviceBuffer>& b, std::size_t bytes, const char* what) {
  if (!b || b->bytes() < bytes) b = std::make_unique<DeviceBuffer>(bytes, what);
}

}  // namespace

GhostTraffic::GhostTraffic() {
  cudaStream_t s = nullptr;
  FF_CUDA_CHECK(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking), "a decomposed team's ghost stream");
  stream_ = s;
  FF_CUDA_CHECK(cudaMallocHost(&flag_host_, sizeof(std::uint32_t)), "a decomposed team's migration flag");
  flag_ = std::make_unique<DeviceBuffer>(sizeof(std::uint32_t), "a decomposed team's migration flag");
}

GhostTraffic::~GhostTraffic() {
  cudaStreamSynchronize(stream_);
  cudaFreeHost(flag_host_);
  cudaStreamDestroy(stream_);
}

void GhostTraffic::wait_for_device() const {
  FF_CUDA_CHECK(cudaDeviceSynchronize(), "waiting for the stages before a ghost exchange");
}

void GhostTraffic::wait() const { FF_CUDA_CHECK(cudaStreamSynchronize(stream_), "a ghost exchange"); }

void GhostTraffic::set_lists(const std::vector<std::vector<std::uint32_t>>& send,
                             const std::vector<std::vector<std::uint32_t>>& recv) {
  auto flatten = [](const std::vector<std::vector<std::uint32_t>>& lists, std::vector<std::size_t>& first,
                    std::vector<std::size_t>& count) {
    std::vector<std::uint32_t> all;
    first.clear();
    count.clear();
    for (auto& l : lists) {
      first.push_back(all.size());
      count.push_back(l.size());
      all.insert(all.end(), l.begin(), l.end());
    }
    return all;
  };
  const std::vector<std::uint32_t> s = flatten(send, send_first_, send_count_);
  const std::vector<std::uint32_t> r = flatten(recv, recv_first_, recv_count_);
  grow(send_idx_, std::max<std::size_t>(1, s.size()) * sizeof(std::uint32_t), "a decomposed team's send list");
  grow(recv_idx_, std::max<std::size_t>(1, r.size()) * sizeof(std::uint32_t), "a decomposed team's receive list");
  // Ordered on this stream: every later pack and unpack runs on it.
  send_idx_->upload(s.data(), s.size() * sizeof(std::uint32_t), stream_);
  recv_idx_->upload(r.data(), r.size() * sizeof(std::uint32_t), stream_);
  wait();  // the host vectors end here
  send_buf_.resize(send.size());
  recv_buf_.resize(recv.size());
}

void* GhostTraffic::send_buffer(int peer, std::size_t bytes) {
  grow(send_buf_[std::size_t(peer)], std::max<std::size_t>(bytes, 1), "a decomposed team's ghost send buffer");
  return send_buf_[std::size_t(peer)]->data();
}

void* GhostTraffic::recv_buffer(int peer, std::size_t bytes) {
  grow(recv_buf_[std::size_t(peer)], std::max<std::size_t>(bytes, 1), "a decomposed team's ghost receive buffer");
  return recv_buf_[std::size_t(peer)]->data();
}

void GhostTraffic::pack(int peer, const void* field, std::size_t entry, std::size_t record, std::size_t offset) {
  const std::size_t n = send_count_[std::size_t(peer)];
  if (!n) return;
  const auto* idx = static_cast<const std::uint32_t*>(send_idx_->data()) + send_first_[std::size_t(peer)];
  void* out = send_buf_[std::size_t(peer)]->data();
  if (word_aligned(entry, record, offset)) {
    const std::size_t words = entry / 4;
    pack_kernel<<<blocks_for(n * words), kThreads, 0, stream_>>>(static_cast<const std::uint32_t*>(field), idx, n,
                                                                   words, static_cast<std::uint32_t*>(out), record / 4,
                                                                   offset / 4);
  } else {
    pack_kernel<<<blocks_for(n * entry), kThreads, 0, stream_>>>(static_cast<const unsigned char*>(field), idx, n,
                                                                   entry, static_cast<unsigned char*>(out), record,
                                                                   offset);
  }
  FF_CUDA_CHECK_LAUNCH("packing ghosts");
}

void GhostTraffic::unpack(int peer, void* field, std::size_t entry, std::size_t record, std::size_t offset) {
  const std::size_t n = recv_count_[std::size_t(peer)];
  if (!n) return;
  const auto* idx = static_cast<const std::uint32_t*>(recv_idx_->data()) + recv_first_[std::size_t(peer)];
  const void* in = recv_buf_[std::size_t(peer)]->data();
  if (word_aligned(entry, record, offset)) {
    const std::size_t words = entry / 4;
    unpack_kernel<<<blocks_for(n * words), kThreads, 0, stream_>>>(static_cast<std::uint32_t*>(field), idx, n, words,
                                                                     static_cast<const std::uint32_t*>(in), record / 4,
                                                                     offset / 4);
  } else {
    unpack_kernel<<<blocks_for(n * entry), kThreads, 0, stream_>>>(static_cast<unsigned char*>(field), idx, n, entry,
                                                                     static_cast<const unsigned char*>(in), record,
                                                                     offset);
  }
  FF_CUDA_CHECK_LAUNCH("unpacking ghosts");
}

void GhostTraffic::set_start(const void* host, std::size_t bytes) {
  grow(start_, std::max<std::size_t>(bytes, 1), "a decomposed team's positions at the migration");
  start_->upload(host, bytes, stream_);
  wait();
}

bool GhostTraffic::moved_beyond(const void* position, bool f32, std::size_t owned, int dim, const double* L,
                                double slack) {
  if (!owned) return false;
  FF_CUDA_CHECK(cudaMemsetAsync(flag_->data(), 0, sizeof(std::uint32_t), stream_), "clearing the migration flag");
  auto* flag = static_cast<std::uint32_t*>(flag_->data());
  if (f32) {
    const float half = float(slack);
    moved_kernel<float><<<blocks_for(owned), kThreads, 0, stream_>>>(
        static_cast<const float*>(position), static_cast<const float*>(start_->data()), owned, dim,
        PeriodicBox<float>::make(L), half * half, flag);
  } else {
    const double half = slack;
    moved_kernel<double><<<blocks_for(owned), kThreads, 0, stream_>>>(
        static_cast<const double*>(position), static_cast<const double*>(start_->data()), owned, dim,
        PeriodicBox<double>::make(L), half * half, flag);
  }
  FF_CUDA_CHECK_LAUNCH("the migration test");
  FF_CUDA_CHECK(cudaMemcpyAsync(flag_host_, flag, sizeof(std::uint32_t), cudaMemcpyDeviceToHost, stream_),
                "reading the migration flag");
  wait();
  return *flag_host_ != 0;
}

}  // namespace ff
