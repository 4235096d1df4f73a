// A decomposed team's migrations (core/run/domain.h): on the host (every particle field
// through host memory; the Delaunay pipelines, and every CPU team) or, on CUDA without fill
// vertices, on the device (core/run/cuda/ghost_traffic.h); and the state rebuilt from what a
// rank keeps and receives. The rest of the domain (the migration test, refreshes, gathering):
// domain.cpp.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "core/base/error.h"
#include "core/run/domain.h"
#include "core/run/domain_staging.h"
#include "core/run/slab.h"

namespace ff {

void Domain::migrate_on_host(State& s) {
  const Layout lay = layout_of(s, s.particle_field_names());
  auto to = std::vector<std::vector<std::uint32_t>>(std::size_t(ranks_));
  const std::vector<double> x = xs(s);
  for (std::size_t i = 0; i < s.n_owned(); ++i) {
    const int o = owner_of(x[i]);
    if (o != rank_) ++changed_owner_;
    for (int q = 0; q < ranks_; ++q)
      if (q == o || ghost_of(q, x[i])) to[std::size_t(q)].push_back(std::uint32_t(i));
  }
  lap("destinations");
  std::vector<std::uint64_t> counts(std::size_t(ranks_), 0), incoming;
  for (int q = 0; q < ranks_; ++q) counts[std::size_t(q)] = to[std::size_t(q)].size();
  exchange_counts(counts, incoming);
  lap("counts");
  auto out = std::vector<std::vector<unsigned char>>(std::size_t(ranks_)), in = out;
  std::vector<Communicator::Transfer> t;
  for (int q = 0; q < ranks_; ++q) {
    if (q == rank_) continue;
    pack(s, lay, to[std::size_t(q)], out[std::size_t(q)]);
    in[std::size_t(q)].resize(incoming[std::size_t(q)] * lay.bytes);
    if (!out[std::size_t(q)].empty()) t.push_back({q, out[std::size_t(q)].data(), out[std::size_t(q)].size(), true});
    if (!in[std::size_t(q)].empty()) t.push_back({q, in[std::size_t(q)].data(), in[std::size_t(q)].size(), false});
  }
  lap("pack");
  transfer(t);
  lap("exchange");
  std::vector<unsigned char> records;
  for (int q = 0; q < ranks_; ++q) records.insert(records.end(), in[std::size_t(q)].begin(), in[std::size_t(q)].end());
  in = {};
  rebuild(s, lay, to[std::size_t(rank_)], records);
}

// The migration on CUDA without the fields leaving the device (core/run/cuda/ghost_traffic.h):
// the same destinations, records, order and lists as migrate_on_host, by kernels; only counts
// come to the host. Not for a team that fills the gap (the Delaunay pipelines: their fill
// vertices are made on the host).
void Domain::migrate_on_device(State& s) {
#ifdef FLIPFLOW_HAVE_CUDA
  GhostTraffic& g = *staging_->traffic;
  g.wait_for_device();
  const Layout lay = layout_of(s, s.particle_field_names());
  std::vector<void*> data;
  for (auto& name : lay.names) {
    Field& f = s.field(name);
    f.acquire(Where::device, Mode::read, g.stream());
    data.push_back(f.device_raw());
  }
  const std::size_t pos_f = lay.index(fields::position), id_f = lay.index(fields::particle_id);
  const bool f32 = s.real() == DType::f32;
  const int D = s.dim();
  const SlabGeometry geo = slab();
  std::uint64_t changed = 0;
  const std::vector<std::size_t> dest = g.destinations(data[pos_f], f32, D, s.n_owned(), geo, &changed);
  changed_owner_ += changed;
  lap("destinations");
  std::vector<std::uint64_t> counts(std::size_t(ranks_), 0), incoming;
  for (int q = 0; q < ranks_; ++q) counts[std::size_t(q)] = dest[std::size_t(q)];
  exchange_counts(counts, incoming);
  lap("counts");
  std::size_t n_in = 0;
  for (int q = 0; q < ranks_; ++q)
    if (q != rank_) n_in += incoming[std::size_t(q)];
  auto* in = static_cast<unsigned char*>(g.records_in(n_in * lay.bytes));
  std::vector<Communicator::Transfer> t;
  std::size_t at = 0;
  for (int q = 0; q < ranks_; ++q) {
    if (q == rank_) continue;
    const std::size_t out_bytes = dest[std::size_t(q)] * lay.bytes, in_bytes = incoming[std::size_t(q)] * lay.bytes;
    if (out_bytes) {
      void* out = g.send_buffer(q, out_bytes);
      for (std::size_t f = 0; f < lay.names.size(); ++f)
        g.pack_destination(q, data[f], lay.size[f], lay.bytes, lay.offset[f], out);
      t.push_back({q, out, out_bytes, true});
    }
    if (in_bytes) {
      t.push_back({q, in + at, in_bytes, false});
      at += in_bytes;
    }
  }
  comm_.exchange(t, g.stream());
  g.wait();
  lap("exchange");
  const std::size_t n = dest[std::size_t(rank_)] + n_in;
  const std::size_t n_owned = g.order(data[pos_f], static_cast<const std::uint32_t*>(data[id_f]), f32, D, n_in,
                                      lay.bytes, lay.offset[pos_f], lay.offset[id_f], geo);
  lap("rebuild: order");
  std::vector<std::unique_ptr<DeviceBuffer>> fresh;
  for (std::size_t f = 0; f < lay.names.size(); ++f) {
    const std::size_t need = std::max<std::size_t>(n * lay.size[f], 1);
    std::unique_ptr<DeviceBuffer> buf = std::move(staging_->spare[lay.names[f]]);
    if (!buf || buf->bytes() < need)  // an eighth more: the held count varies from one migration to the next
      buf = std::make_unique<DeviceBuffer>(need + need / 8, "field '" + lay.names[f] + "' after a migration");
    g.gather(buf->data(), data[f], lay.size[f], lay.bytes, lay.offset[f]);
    fresh.push_back(std::move(buf));
  }
  g.wait();  // the fields' old storage is read until here
  for (std::size_t f = 0; f < lay.names.size(); ++f)
    staging_->spare[lay.names[f]] = s.field(lay.names[f]).adopt_device(std::move(fresh[f]), n);
  n_held_ = n;
  s.set_particles(n, n_owned);
  lap("rebuild: fields");
  Field& pos = s.field(fields::position);
  g.set_start_from(pos.device_raw(), n_owned * std::size_t(D) * dtype_size(s.real()));
  x0_on_host_ = false;
  g.held_lists(pos.device_raw(), f32, D, n_owned, n, geo, send_, recv_);
  lap("rebuild: lists");
#else
  (void)s;
#endif
}

namespace {

// dst[k] = *src(k) for k < n, entries of `size` bytes; the common sizes as fixed-size copies
// (a migration copies every particle field of about a million particles a GPU).
template <class Src>
void gather_entries(unsigned char* dst, std::size_t size, std::size_t n, const Src& src) {
  auto copy = [&](auto fixed) {
    constexpr std::size_t S = decltype(fixed)::value;
    for (std::size_t k = 0; k < n; ++k) std::memcpy(dst + k * S, src(k), S);
  };
  switch (size) {
    case 1: copy(std::integral_constant<std::size_t, 1>{}); break;
    case 4: copy(std::integral_constant<std::size_t, 4>{}); break;
    case 8: copy(std::integral_constant<std::size_t, 8>{}); break;
    case 12: copy(std::integral_constant<std::size_t, 12>{}); break;
    case 16: copy(std::integral_constant<std::size_t, 16>{}); break;
    case 24: copy(std::integral_constant<std::size_t, 24>{}); break;
    default:
      for (std::size_t k = 0; k < n; ++k) std::memcpy(dst + k * size, src(k), size);
  }
}

}  // namespace

void Domain::rebuild(State& s, const Layout& lay, const std::vector<std::uint32_t>& kept,
                     const std::vector<unsigned char>& records) {
  const std::size_t n_kept = kept.size(), n = n_kept + (lay.bytes ? records.size() / lay.bytes : 0);
  const std::size_t pos_f = lay.index(fields::position), id_f = lay.index(fields::particle_id);
  // Source k < n_kept: the kept particle kept[k] of the fields as they are; else a record.
  std::vector<const unsigned char*> current(lay.names.size());
  for (std::size_t f = 0; f < lay.names.size(); ++f) {
    Field& field = s.field(lay.names[f]);
    field.acquire(Where::host, Mode::read);
    current[f] = static_cast<const unsigned char*>(field.host_raw());
  }
  auto entry = [&](std::size_t f, std::size_t k) {
    return k < n_kept ? current[f] + std::size_t(kept[k]) * lay.size[f]
                      : &records[(k - n_kept) * lay.bytes + lay.offset[f]];
  };
  auto x_of = [&](std::size_t k) {
    if (s.real() == DType::f32) {
      float v;
      std::memcpy(&v, entry(pos_f, k), sizeof v);
      return double(v);
    }
    double v;
    std::memcpy(&v, entry(pos_f, k), sizeof v);
    return v;
  };
  // Owned first, then ghosts; each by id (a particle arrives once: from its one previous owner).
  // One key a source (slab.h's held_key; n < 2^31).
  if (n >= (std::size_t(1) << 31))
    throw RunError("a rank of a decomposed team would hold " + std::to_string(n) + " particles: at most 2^31");
  std::vector<std::uint64_t> key(n);
  std::size_t n_owned = 0;
  for (std::size_t k = 0; k < n; ++k) {
    std::uint32_t id;
    std::memcpy(&id, entry(id_f, k), sizeof id);
    const bool owned = owner_of(x_of(k)) == rank_;
    n_owned += owned ? 1 : 0;
    key[k] = held_key(owned, id, k);
  }
  std::sort(key.begin(), key.end());
  std::vector<std::size_t> order(n);
  for (std::size_t k = 0; k < n; ++k) order[k] = std::size_t(key[k] & kHeldSourceMask);
  key = {};
  lap("rebuild: order");
  // The fill vertices: each a copy of the first held particle's entries (so a type and a
  // diameter that exist), with its own position and particle.id kFillId.
  const std::vector<double> fill = fill_gap_ ? fill_points(s) : std::vector<double>{};
  const std::size_t n_fill = fill.size() / 2;
  if (n_fill && n == 0) throw RunError("a rank of a decomposed team holds no particle: use fewer ranks");
  std::vector<std::vector<unsigned char>> fresh(lay.names.size());
  for (std::size_t f = 0; f < lay.names.size(); ++f) {
    const std::size_t sz = lay.size[f];
    fresh[f].resize((n + n_fill) * sz);
    unsigned char* dst = fresh[f].data();
    gather_entries(dst, sz, n, [&](std::size_t k) { return entry(f, order[k]); });
    for (std::size_t k = 0; k < n_fill; ++k) {
      unsigned char* d = dst + (n + k) * sz;
      if (f == pos_f) {
        for (int c = 0; c < 2; ++c) {
          if (s.real() == DType::f32) {
            const float v = float(fill[2 * k + std::size_t(c)]);
            std::memcpy(d + std::size_t(c) * sizeof v, &v, sizeof v);
          } else {
            std::memcpy(d + std::size_t(c) * sizeof(double), &fill[2 * k + std::size_t(c)], sizeof(double));
          }
        }
      } else if (f == id_f) {
        std::memcpy(d, &fields::kFillId, sizeof fields::kFillId);
      } else {
        std::memcpy(d, entry(f, order[0]), sz);
      }
    }
  }
  // Only now: the kept particles are read from the fields as they were.
  for (std::size_t f = 0; f < lay.names.size(); ++f) {
    Field& field = s.field(lay.names[f]);
    field.resize(n + n_fill);
    field.acquire(Where::host, Mode::write);
    if (!fresh[f].empty()) std::memcpy(field.host_raw(), fresh[f].data(), fresh[f].size());
    fresh[f] = {};
  }
  lap("rebuild: fields");
  n_held_ = n;
  s.set_particles(n + n_fill, n_owned);
  to_device(s, {fields::particle_id});  // read by the stages' kernels without an Access of their own
  Field& pos = s.field(fields::position);
  const std::size_t D = std::size_t(s.dim());
  x0_.resize(n_owned * D);
  x0_on_host_ = true;
  for (std::size_t i = 0; i < n_owned * D; ++i)
    x0_[i] = s.real() == DType::f32 ? double(pos.host<float>()[i]) : pos.host<double>()[i];
#ifdef FLIPFLOW_HAVE_CUDA
  if (staging_->traffic) staging_->traffic->set_start(pos.host_raw(), n_owned * D * dtype_size(s.real()));
#endif
  set_lists(s);
  lap("rebuild: lists");
}

std::vector<double> Domain::fill_points(const State& s) const {
  std::vector<double> out;
  const double lo = L_ * double(rank_) / double(ranks_), hi = L_ * double(rank_ + 1) / double(ranks_);
  const double Ly = s.box.L[1];
  const double gap = L_ - (hi - lo + 2 * band_);
  if (!(gap > 0)) return out;
  const int nx = std::max(1, int(std::ceil(gap / band_))), ny = std::max(3, int(std::ceil(Ly / band_)));
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) {
      double x = hi + band_ + (i + 0.5) * gap / nx;
      x -= L_ * std::floor(x / L_);
      out.push_back(x);
      out.push_back((j + 0.25 + 0.5 * (i % 2)) * Ly / ny);
    }
  return out;
}

}  // namespace ff
