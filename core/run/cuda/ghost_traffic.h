// The device half of a decomposed team's per-step traffic on CUDA (core/run/domain.h): the
// ghost refresh and the migration test, without the fields leaving the device. A refresh packs
// the owners' entries of the refreshed fields into one device buffer per peer by the index lists
// of the last migration (kept on the device), exchanges the buffers through the communicator
// on this object's stream, and unpacks what arrives into the ghosts' entries; the migration test
// is neighbors.verlet's arithmetic (MovedTooFar, -fmad=false) over the owned particles, one flag
// read back. The first version copied whole fields to the host and back in each of them (twice
// per step, and per iteration of overlap_correct.verlet): tens of milliseconds a step at 2^20
// particles a GPU (bench/README.md, session 20).
//
// nvcc-clean C++ interface (domain.cpp is compiled by the host compiler); CUDA builds only.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/run/slab.h"

struct CUstream_st;

namespace ff {

class DeviceBuffer;


class GhostTraffic {
 public:
  GhostTraffic();  // a stream on the current device (the rank's)
  ~GhostTraffic();
  GhostTraffic(const GhostTraffic&) = delete;
  GhostTraffic& operator=(const GhostTraffic&) = delete;

  CUstream_st* stream() const { return stream_; }
  // Every stage's work done, on whatever stream it ran (the stages' streams do not order with
  // this one): before anything here reads what a stage wrote.
  void wait_for_device() const;
  // This object's stream done: after it, the stages' streams see what it wrote.
  void wait() const;

  // The refresh's index lists of the last migration (Domain::send_ and recv_: per peer, local
  // indices in id order), copied to the device.
  void set_lists(const std::vector<std::vector<std::uint32_t>>& send, const std::vector<std::vector<std::uint32_t>>& recv);
  // Device buffers of at least `bytes` for what goes to, and comes from, `peer` (grown as needed).
  void* send_buffer(int peer, std::size_t bytes);
  void* recv_buffer(int peer, std::size_t bytes);
  // One field's entries (entry_bytes each) of send[peer]'s particles into the send buffer of
  // `peer`: record k at k·record_bytes + offset; and the reverse into recv[peer]'s particles.
  void pack(int peer, const void* field, std::size_t entry_bytes, std::size_t record_bytes, std::size_t offset);
  void unpack(int peer, void* field, std::size_t entry_bytes, std::size_t record_bytes, std::size_t offset);

  // The owned positions at the migration (n·dim reals of the state's precision, from the host).
  void set_start(const void* host, std::size_t bytes);
  // Whether some of the first `owned` particles of `position` (device, dim reals each, float or
  // double) is farther than `slack` (minimum image in the box L) from its position at the
  // migration; waits for the answer.
  bool moved_beyond(const void* position, bool f32, std::size_t owned, int dim, const double* L, double slack);
  // The start positions from the device: the owned positions of `position` now (after a
  // migration on the device), and back to the host (Domain::displacement).
  void set_start_from(const void* position, std::size_t bytes);
  void get_start(void* host, std::size_t bytes) const;

  // A migration on the device (Domain::migrate_on_device), in this order. Waits where it returns
  // counts. destinations: for every rank q, the owned particles (of `owned`, positions of the
  // state's precision) that go to q: q owns it now, or holds it as a ghost; their counts, and
  // how many change owner.
  std::vector<std::size_t> destinations(const void* position, bool f32, int dim, std::size_t owned,
                                        const SlabGeometry& geo, std::uint64_t* changed_owner);
  // One field's entries of destination q's particles into `out` (records as in pack).
  void pack_destination(int q, const void* field, std::size_t entry_bytes, std::size_t record_bytes,
                        std::size_t offset, void* out);
  // Where every peer's records arrive, one after another (grown as needed).
  void* records_in(std::size_t bytes);
  // The held particles from now on: this rank's own destinations (kept, from the fields as they
  // are) and the n_in records, owned first, then ghosts, each by id (one 64-bit key a particle,
  // radix-sorted). Returns how many are owned.
  std::size_t order(const void* position, const std::uint32_t* id, bool f32, int dim, std::size_t n_in,
                    std::size_t record_bytes, std::size_t position_offset, std::size_t id_offset,
                    const SlabGeometry& geo);
  // One field of the held particles in that order into dst (a kept particle's entry from `field`,
  // a received one's from its record).
  void gather(void* dst, const void* field, std::size_t entry_bytes, std::size_t record_bytes, std::size_t offset);
  // The refresh lists of the held particles (`owned` of `n`): per peer q, the owned particles q
  // holds as ghosts and the ghosts q owns, in index (id) order; into `send` and `recv`, then
  // set_lists.
  void held_lists(const void* position, bool f32, int dim, std::size_t owned, std::size_t n, const SlabGeometry& geo,
                  std::vector<std::vector<std::uint32_t>>& send, std::vector<std::vector<std::uint32_t>>& recv);

 private:
  CUstream_st* stream_ = nullptr;
  std::vector<std::size_t> send_first_, send_count_, recv_first_, recv_count_;  // per peer, into the lists
  std::unique_ptr<DeviceBuffer> send_idx_, recv_idx_, start_, flag_;
  std::vector<std::unique_ptr<DeviceBuffer>> send_buf_, recv_buf_;
  std::uint32_t* flag_host_ = nullptr;  // pinned
  // The migration's: per rank, its destinations' indices (rank q's at q·owned), their counts,
  // the flags and scan they are compacted from, the keys before and after the sort, the records in.
  std::size_t dest_stride_ = 0, n_kept_ = 0, n_in_ = 0;
  std::vector<std::size_t> dest_count_;
  const std::uint32_t* kept_ = nullptr;  // order()'s kept particles (this rank's destinations)
  std::unique_ptr<DeviceBuffer> dest_, flags_, scan_, keys_, sorted_, temp_, records_in_, counter_;
  // Compacts the indices i < n with flags[i] != 0 into out (ascending); returns their count.
  std::size_t compact(const std::uint32_t* flags, std::size_t n, std::uint32_t* out);
};

}  // namespace ff
