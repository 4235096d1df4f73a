#include "core/run/cuda/ghost_traffic.h"

#include <cub/cub.cuh>

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/device_buffer.h"
#include "core/backend/host_wait.h"
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

// The migration test over the owned particles (slab.h's moved_squared, as the host's).
template <class R>
__global__ void moved_kernel(const R* __restrict__ x, const R* __restrict__ x0, std::size_t owned, int dim,
                             PeriodicBox<R> box, R limit2, std::uint32_t* flag) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= owned) return;
  if (moved_squared(x, x0, i, dim, box) > limit2) *flag = 1u;  // every writer stores the same value
}

template <class R>
__global__ void destinations_kernel(const R* __restrict__ x, int dim, std::size_t owned, SlabGeometry g,
                                    std::uint32_t* __restrict__ flags, unsigned long long* changed) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= owned) return;
  const double xi = double(x[i * std::size_t(dim)]);
  const int o = g.owner_of(xi);
  if (o != g.rank) atomicAdd(changed, 1ull);
  for (int q = 0; q < g.ranks; ++q) flags[std::size_t(q) * owned + i] = (q == o || g.ghost_of(q, xi)) ? 1u : 0u;
}

// The refresh lists' flags: for an owned particle, whether peer q holds it as a ghost; for a
// ghost, whether q owns it.
template <class R>
__global__ void held_flags_kernel(const R* __restrict__ x, int dim, std::size_t owned, std::size_t n, int q,
                                  SlabGeometry g, std::uint32_t* __restrict__ send, std::uint32_t* __restrict__ recv) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const double xi = double(x[i * std::size_t(dim)]);
  if (i < owned) send[i] = g.ghost_of(q, xi) ? 1u : 0u;
  else recv[i - owned] = g.owner_of(xi) == q ? 1u : 0u;
}

__global__ void scatter_kernel(const std::uint32_t* __restrict__ flags, const std::uint32_t* __restrict__ scan,
                               std::size_t n, std::uint32_t* __restrict__ out, std::uint32_t* count) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  if (flags[i]) out[scan[i]] = std::uint32_t(i);
  if (i == n - 1) *count = scan[i] + flags[i];
}

// One key a held particle: bit 63 a ghost, then its id, then its source (a kept particle k <
// n_kept, else record k - n_kept): sorted, owned first, then ghosts, each by id.
template <class R>
__global__ void keys_kernel(const R* __restrict__ x, const std::uint32_t* __restrict__ id,
                            const std::uint32_t* __restrict__ kept, std::size_t n_kept,
                            const unsigned char* __restrict__ records, std::size_t n_in, std::size_t record,
                            std::size_t position_offset, std::size_t id_offset, int dim, SlabGeometry g,
                            std::uint64_t* __restrict__ keys, unsigned long long* owned) {
  const std::size_t k = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (k >= n_kept + n_in) return;
  double xk;
  std::uint32_t pid;
  if (k < n_kept) {
    xk = double(x[std::size_t(kept[k]) * std::size_t(dim)]);
    pid = id[kept[k]];
  } else {
    const unsigned char* rec = records + (k - n_kept) * record;
    R v;
    memcpy(&v, rec + position_offset, sizeof v);
    xk = double(v);
    memcpy(&pid, rec + id_offset, sizeof pid);
  }
  const bool mine = g.owner_of(xk) == g.rank;
  if (mine) atomicAdd(owned, 1ull);
  keys[k] = held_key(mine, pid, k);
}

template <class W>
__global__ void gather_kernel(W* __restrict__ dst, const W* __restrict__ field, const std::uint32_t* __restrict__ kept,
                              std::size_t n_kept, const W* __restrict__ records, const std::uint64_t* __restrict__ keys,
                              std::size_t n, std::size_t words, std::size_t record_words, std::size_t offset_words) {
  const std::size_t t = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (t >= n * words) return;
  const std::size_t k = t / words, w = t % words;
  const std::size_t src = std::size_t(keys[k] & kHeldSourceMask);
  dst[k * words + w] = src < n_kept ? field[std::size_t(kept[src]) * words + w]
                                    : records[(src - n_kept) * record_words + offset_words + w];
}

// Calls launch(unit, entry, record, offset) in the copy's unit: 32-bit words (a std::uint32_t
// unit, the sizes divided by 4) when every entry, record and offset allows it, else bytes (an
// unsigned char unit). The kernels above are instantiated for both.
template <class Launch>
void in_copy_units(std::size_t entry, std::size_t record, std::size_t offset, Launch&& launch) {
  if (entry % 4 == 0 && record % 4 == 0 && offset % 4 == 0)
    launch(std::uint32_t{}, entry / 4, record / 4, offset / 4);
  else
    launch(static_cast<unsigned char>(0), entry, record, offset);
}

void grow(std::unique_ptr<DeviceBuffer>& b, std::size_t bytes, const char* what) {
  if (!b || b->bytes() < bytes) b = std::make_unique<DeviceBuffer>(bytes, what);
}

// n entries of `entry` bytes, field[idx[k]], into records of `record` bytes at `offset` in out.
void launch_pack(const void* field, const std::uint32_t* idx, std::size_t n, std::size_t entry, std::size_t record,
                 std::size_t offset, void* out, cudaStream_t stream) {
  in_copy_units(entry, record, offset, [&](auto unit, std::size_t e, std::size_t r, std::size_t o) {
    using W = decltype(unit);
    pack_kernel<<<blocks_for(n * e), kThreads, 0, stream>>>(static_cast<const W*>(field), idx, n, e, static_cast<W*>(out),
                                                              r, o);
  });
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
  const HostWait waiting;
  FF_CUDA_CHECK(cudaDeviceSynchronize(), "waiting for the stages before a ghost exchange");
}

void GhostTraffic::wait() const {
  const HostWait waiting;
  FF_CUDA_CHECK(cudaStreamSynchronize(stream_), "a ghost exchange");
}

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
  launch_pack(field, idx, n, entry, record, offset, send_buf_[std::size_t(peer)]->data(), stream_);
  FF_CUDA_CHECK_LAUNCH("packing ghosts");
}

void GhostTraffic::unpack(int peer, void* field, std::size_t entry, std::size_t record, std::size_t offset) {
  const std::size_t n = recv_count_[std::size_t(peer)];
  if (!n) return;
  const auto* idx = static_cast<const std::uint32_t*>(recv_idx_->data()) + recv_first_[std::size_t(peer)];
  const void* in = recv_buf_[std::size_t(peer)]->data();
  in_copy_units(entry, record, offset, [&](auto unit, std::size_t e, std::size_t r, std::size_t o) {
    using W = decltype(unit);
    unpack_kernel<<<blocks_for(n * e), kThreads, 0, stream_>>>(static_cast<W*>(field), idx, n, e,
                                                                 static_cast<const W*>(in), r, o);
  });
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

void GhostTraffic::set_start_from(const void* position, std::size_t bytes) {
  grow(start_, std::max<std::size_t>(bytes, 1), "a decomposed team's positions at the migration");
  if (bytes)
    FF_CUDA_CHECK(cudaMemcpyAsync(start_->data(), position, bytes, cudaMemcpyDeviceToDevice, stream_),
                  "keeping the positions at the migration");
  wait();
}

void GhostTraffic::get_start(void* host, std::size_t bytes) const {
  if (!bytes) return;
  FF_CUDA_CHECK(cudaMemcpyAsync(host, start_->data(), bytes, cudaMemcpyDeviceToHost, stream_),
                "reading the positions at the migration");
  wait();
}

std::size_t GhostTraffic::compact(const std::uint32_t* flags, std::size_t n, std::uint32_t* out) {
  if (!n) return 0;
  grow(scan_, n * sizeof(std::uint32_t), "a decomposed team's migration scan");
  grow(counter_, 2 * sizeof(unsigned long long), "a decomposed team's migration counters");
  auto* scan = static_cast<std::uint32_t*>(scan_->data());
  std::size_t temp_bytes = 0;
  FF_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, temp_bytes, flags, scan, int(n), stream_),
                "sizing a migration scan");
  grow(temp_, std::max<std::size_t>(temp_bytes, 1), "a decomposed team's migration scratch");
  FF_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(temp_->data(), temp_bytes, flags, scan, int(n), stream_),
                "a migration scan");
  auto* count = static_cast<std::uint32_t*>(counter_->data());
  scatter_kernel<<<blocks_for(n), kThreads, 0, stream_>>>(flags, scan, n, out, count);
  FF_CUDA_CHECK_LAUNCH("compacting a migration list");
  FF_CUDA_CHECK(cudaMemcpyAsync(flag_host_, count, sizeof(std::uint32_t), cudaMemcpyDeviceToHost, stream_),
                "reading a migration count");
  wait();
  return *flag_host_;
}

std::vector<std::size_t> GhostTraffic::destinations(const void* position, bool f32, int dim, std::size_t owned,
                                                    const SlabGeometry& geo, std::uint64_t* changed_owner) {
  const std::size_t ranks = std::size_t(geo.ranks);
  dest_stride_ = owned;
  dest_count_.assign(ranks, 0);
  *changed_owner = 0;
  if (!owned) return dest_count_;
  grow(dest_, ranks * owned * sizeof(std::uint32_t), "a decomposed team's migration lists");
  grow(flags_, ranks * owned * sizeof(std::uint32_t), "a decomposed team's migration flags");
  grow(counter_, 2 * sizeof(unsigned long long), "a decomposed team's migration counters");
  auto* flags = static_cast<std::uint32_t*>(flags_->data());
  auto* changed = static_cast<unsigned long long*>(counter_->data()) + 1;
  FF_CUDA_CHECK(cudaMemsetAsync(changed, 0, sizeof(unsigned long long), stream_), "clearing a migration counter");
  if (f32)
    destinations_kernel<float><<<blocks_for(owned), kThreads, 0, stream_>>>(static_cast<const float*>(position), dim,
                                                                             owned, geo, flags, changed);
  else
    destinations_kernel<double><<<blocks_for(owned), kThreads, 0, stream_>>>(static_cast<const double*>(position), dim,
                                                                              owned, geo, flags, changed);
  FF_CUDA_CHECK_LAUNCH("a migration's destinations");
  unsigned long long moved = 0;
  FF_CUDA_CHECK(cudaMemcpyAsync(&moved, changed, sizeof moved, cudaMemcpyDeviceToHost, stream_),
                "reading a migration counter");
  wait();
  *changed_owner = moved;
  auto* dest = static_cast<std::uint32_t*>(dest_->data());
  for (std::size_t q = 0; q < ranks; ++q) dest_count_[q] = compact(flags + q * owned, owned, dest + q * owned);
  return dest_count_;
}

void GhostTraffic::pack_destination(int q, const void* field, std::size_t entry, std::size_t record,
                                    std::size_t offset, void* out) {
  const std::size_t n = dest_count_[std::size_t(q)];
  if (!n) return;
  const auto* idx = static_cast<const std::uint32_t*>(dest_->data()) + std::size_t(q) * dest_stride_;
  launch_pack(field, idx, n, entry, record, offset, out, stream_);
  FF_CUDA_CHECK_LAUNCH("packing a migration's records");
}

void* GhostTraffic::records_in(std::size_t bytes) {
  grow(records_in_, std::max<std::size_t>(bytes, 1), "a decomposed team's migration records");
  return records_in_->data();
}

std::size_t GhostTraffic::order(const void* position, const std::uint32_t* id, bool f32, int dim, std::size_t n_in,
                                std::size_t record, std::size_t position_offset, std::size_t id_offset,
                                const SlabGeometry& geo) {
  n_kept_ = dest_count_.empty() ? 0 : dest_count_[std::size_t(geo.rank)];
  n_in_ = n_in;
  const std::size_t n = n_kept_ + n_in_;
  if (!n) return 0;
  if (n >= (std::size_t(1) << 31)) throw std::runtime_error("a rank of a decomposed team would hold 2^31 particles or more");
  grow(keys_, n * sizeof(std::uint64_t), "a decomposed team's migration keys");
  grow(sorted_, n * sizeof(std::uint64_t), "a decomposed team's migration keys");
  grow(counter_, 2 * sizeof(unsigned long long), "a decomposed team's migration counters");
  grow(records_in_, 1, "a decomposed team's migration records");
  auto* owned = static_cast<unsigned long long*>(counter_->data());
  FF_CUDA_CHECK(cudaMemsetAsync(owned, 0, sizeof(unsigned long long), stream_), "clearing a migration counter");
  const std::uint32_t* kept =
      n_kept_ ? static_cast<const std::uint32_t*>(dest_->data()) + std::size_t(geo.rank) * dest_stride_ : nullptr;
  kept_ = kept;
  auto* keys = static_cast<std::uint64_t*>(keys_->data());
  auto* sorted = static_cast<std::uint64_t*>(sorted_->data());
  const auto* records = static_cast<const unsigned char*>(records_in_->data());
  if (f32)
    keys_kernel<float><<<blocks_for(n), kThreads, 0, stream_>>>(static_cast<const float*>(position), id, kept, n_kept_,
                                                                 records, n_in_, record, position_offset, id_offset, dim,
                                                                 geo, keys, owned);
  else
    keys_kernel<double><<<blocks_for(n), kThreads, 0, stream_>>>(static_cast<const double*>(position), id, kept,
                                                                  n_kept_, records, n_in_, record, position_offset,
                                                                  id_offset, dim, geo, keys, owned);
  FF_CUDA_CHECK_LAUNCH("a migration's keys");
  std::size_t temp_bytes = 0;
  FF_CUDA_CHECK(cub::DeviceRadixSort::SortKeys(nullptr, temp_bytes, keys, sorted, int(n), 0, 64, stream_),
                "sizing a migration's sort");
  grow(temp_, std::max<std::size_t>(temp_bytes, 1), "a decomposed team's migration scratch");
  FF_CUDA_CHECK(cub::DeviceRadixSort::SortKeys(temp_->data(), temp_bytes, keys, sorted, int(n), 0, 64, stream_),
                "a migration's sort");
  unsigned long long mine = 0;
  FF_CUDA_CHECK(cudaMemcpyAsync(&mine, owned, sizeof mine, cudaMemcpyDeviceToHost, stream_),
                "reading a migration counter");
  wait();
  return std::size_t(mine);
}

void GhostTraffic::gather(void* dst, const void* field, std::size_t entry, std::size_t record, std::size_t offset) {
  const std::size_t n = n_kept_ + n_in_;
  if (!n) return;
  const auto* sorted = static_cast<const std::uint64_t*>(sorted_->data());
  const std::uint32_t* kept_list = kept_;
  in_copy_units(entry, record, offset, [&](auto unit, std::size_t e, std::size_t r, std::size_t o) {
    using W = decltype(unit);
    gather_kernel<<<blocks_for(n * e), kThreads, 0, stream_>>>(static_cast<W*>(dst), static_cast<const W*>(field),
                                                                 kept_list, n_kept_,
                                                                 static_cast<const W*>(records_in_->data()), sorted, n,
                                                                 e, r, o);
  });
  FF_CUDA_CHECK_LAUNCH("gathering a field after a migration");
}

void GhostTraffic::held_lists(const void* position, bool f32, int dim, std::size_t owned, std::size_t n,
                              const SlabGeometry& geo, std::vector<std::vector<std::uint32_t>>& send,
                              std::vector<std::vector<std::uint32_t>>& recv) {
  const std::size_t ranks = std::size_t(geo.ranks);
  send.assign(ranks, {});
  recv.assign(ranks, {});
  const std::size_t ghosts = n - owned;
  grow(flags_, std::max<std::size_t>(n, 1) * sizeof(std::uint32_t), "a decomposed team's migration flags");
  grow(dest_, std::max<std::size_t>(n, 1) * sizeof(std::uint32_t), "a decomposed team's migration lists");
  auto* flags = static_cast<std::uint32_t*>(flags_->data());
  auto* list = static_cast<std::uint32_t*>(dest_->data());
  for (std::size_t q = 0; q < ranks; ++q) {
    if (int(q) == geo.rank || !n) continue;
    if (f32)
      held_flags_kernel<float><<<blocks_for(n), kThreads, 0, stream_>>>(static_cast<const float*>(position), dim, owned,
                                                                         n, int(q), geo, flags, flags + owned);
    else
      held_flags_kernel<double><<<blocks_for(n), kThreads, 0, stream_>>>(static_cast<const double*>(position), dim,
                                                                          owned, n, int(q), geo, flags, flags + owned);
    FF_CUDA_CHECK_LAUNCH("a migration's refresh lists");
    const std::size_t ns = compact(flags, owned, list);
    const std::size_t nr = compact(flags + owned, ghosts, list + owned);
    send[q].resize(ns);
    recv[q].resize(nr);
    if (ns)
      FF_CUDA_CHECK(cudaMemcpyAsync(send[q].data(), list, ns * sizeof(std::uint32_t), cudaMemcpyDeviceToHost, stream_),
                    "reading a refresh list");
    if (nr)
      FF_CUDA_CHECK(cudaMemcpyAsync(recv[q].data(), list + owned, nr * sizeof(std::uint32_t), cudaMemcpyDeviceToHost,
                                    stream_),
                    "reading a refresh list");
    wait();
    for (auto& i : recv[q]) i += std::uint32_t(owned);  // compacted among the ghosts
  }
  dest_count_.clear();  // the migration's lists are gone (dest_ reused)
  kept_ = nullptr;
  set_lists(send, recv);
}

}  // namespace ff
