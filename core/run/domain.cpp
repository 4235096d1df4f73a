#include "core/run/domain.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numeric>

#include "core/backend/not_computed.h"
#include "core/base/error.h"
#include "core/physics/box.h"
#include "core/run/domain_staging.h"
#include "core/run/slab.h"

namespace ff {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

Domain::~Domain() = default;

void Domain::transfer(const std::vector<Communicator::Transfer>& t) {
  if (backend_ != Backend::cuda) {
    comm_.exchange(t, nullptr);
    return;
  }
#ifdef FLIPFLOW_HAVE_CUDA
  auto& buf = staging_->buffers;
  if (buf.size() < t.size()) buf.resize(t.size());
  std::vector<Communicator::Transfer> on_device = t;
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (!buf[k] || buf[k]->bytes() < t[k].bytes)
      buf[k] = std::make_unique<DeviceBuffer>(t[k].bytes, "a decomposed team's exchange buffer");
    on_device[k].data = buf[k]->data();
    if (t[k].send) buf[k]->upload(t[k].data, t[k].bytes, nullptr);
  }
  comm_.exchange(on_device, nullptr);  // the legacy stream: ordered after the uploads
  for (std::size_t k = 0; k < t.size(); ++k)
    if (!t[k].send) buf[k]->download(t[k].data, t[k].bytes, nullptr);
#else
  throw RunError("a decomposed team on CUDA in a build without CUDA");
#endif
}

void Domain::to_device(State& s, const std::vector<std::string>& names) const {
  if (backend_ != Backend::cuda) return;
  for (auto& n : names) s.field(n).acquire(Where::device, Mode::read);
}

namespace {

// Whether some particle [0, owned) moved more than `slack` (minimum image) from x0: the
// arithmetic of neighbors.verlet's rebuild test (MovedTooFar) in the state's precision.
template <class R>
bool moved_beyond(State& s, const std::vector<double>& x0, double slack) {
  Field& pos = s.field(fields::position);
  pos.acquire(Where::host, Mode::read);
  const R* x = pos.host<R>();
  const PeriodicBox<R> box = PeriodicBox<R>::make(s.box.L);
  const R half = R(slack);
  const R limit2 = half * half;
  for (std::size_t i = 0; i < s.n_owned(); ++i)
    if (moved_squared(x, x0.data(), i, s.dim(), box) > limit2) return true;
  return false;
}

std::size_t entry_bytes(const Field& f) { return dtype_size(f.dtype()) * std::size_t(f.components()); }

}  // namespace

Domain::Domain(Communicator& comm, State& s, double band, double slack, std::vector<std::string> refreshed,
               Backend backend, bool fill_gap)
    : comm_(comm), rank_(comm.rank()), ranks_(comm.size()), L_(s.box.L[0]), band_(band), slack_(slack),
      fill_gap_(fill_gap), refreshed_(std::move(refreshed)), send_(std::size_t(ranks_)), recv_(std::size_t(ranks_)),
      backend_(backend), staging_(std::make_unique<Staging>()) {
  if (fill_gap_ && s.dim() != 2)
    throw InputError("a decomposed team fills the gap beyond the band with fixed vertices in 2D only");
  if (fill_gap_ && !(band_ > 0)) throw InputError("a decomposed team that fills the gap needs a band > 0");
#ifdef FLIPFLOW_HAVE_CUDA
  if (backend_ == Backend::cuda) staging_->traffic = std::make_unique<GhostTraffic>();
#endif
  for (const std::string& name : s.particle_field_names())
    if (not_computed(s.field(name))) not_computed_.push_back(name);
  // Global ids, then this rank's share of the whole state (the same on every rank: no message).
  Field& id = s.add_particle_field(fields::particle_id, DType::u32, 1);
  id.acquire(Where::host, Mode::write);
  std::iota(id.host<std::uint32_t>(), id.host<std::uint32_t>() + s.n(), 0u);
  const Layout lay = layout_of(s, s.particle_field_names());
  std::vector<std::uint32_t> mine;
  const std::vector<double> x = xs(s);
  for (std::size_t i = 0; i < s.n(); ++i)
    if (owner_of(x[i]) == rank_ || ghost_of(rank_, x[i])) mine.push_back(std::uint32_t(i));
  rebuild(s, lay, mine, {});
}

std::vector<double> Domain::xs(State& s) const {
  Field& pos = s.field(fields::position);
  pos.acquire(Where::host, Mode::read);
  const std::size_t D = std::size_t(s.dim());
  std::vector<double> x(s.n());
  for (std::size_t i = 0; i < s.n(); ++i)
    x[i] = s.real() == DType::f32 ? double(pos.host<float>()[i * D]) : pos.host<double>()[i * D];
  return x;
}

int Domain::owner_of(double x) const { return slab().owner_of(x); }

bool Domain::ghost_of(int q, double x) const { return slab().ghost_of(q, x); }

Domain::Layout Domain::layout_of(const State& s, const std::vector<std::string>& names) const {
  Layout lay;
  lay.names = names;
  if (lay.index(fields::particle_id) == lay.names.size())
    lay.names.push_back(fields::particle_id);
  for (auto& n : lay.names) {
    if (n == fields::particle_id) lay.id_offset = lay.bytes;
    lay.offset.push_back(lay.bytes);
    lay.size.push_back(entry_bytes(s.field(n)));
    lay.bytes += lay.size.back();
  }
  return lay;
}

void Domain::pack(State& s, const Layout& lay, const std::vector<std::uint32_t>& which,
                  std::vector<unsigned char>& out) const {
  const std::size_t start = out.size();
  out.resize(start + which.size() * lay.bytes);
  for (std::size_t f = 0; f < lay.names.size(); ++f) {
    Field& field = s.field(lay.names[f]);
    field.acquire(Where::host, Mode::read);
    const auto* src = static_cast<const unsigned char*>(field.host_raw());
    const std::size_t sz = lay.size[f];
    for (std::size_t k = 0; k < which.size(); ++k)
      std::memcpy(&out[start + k * lay.bytes + lay.offset[f]], src + std::size_t(which[k]) * sz, sz);
  }
}

// Who sends what to whom in a refresh: the owner of a ghost decides from the same position
// bits the migration did, so both sides list the same particles in the same (id) order.
void Domain::set_lists(State& s) {
  for (auto& l : send_) l.clear();
  for (auto& l : recv_) l.clear();
  const std::vector<double> x = xs(s);
  for (std::size_t i = 0; i < n_held_; ++i) {
    if (i < s.n_owned()) {
      for (int q = 0; q < ranks_; ++q)
        if (q != rank_ && ghost_of(q, x[i])) send_[std::size_t(q)].push_back(std::uint32_t(i));
    } else {
      recv_[std::size_t(owner_of(x[i]))].push_back(std::uint32_t(i));
    }
  }
#ifdef FLIPFLOW_HAVE_CUDA
  if (staging_->traffic) staging_->traffic->set_lists(send_, recv_);
#endif
}

void Domain::exchange_counts(const std::vector<std::uint64_t>& send, std::vector<std::uint64_t>& recv) {
  recv.assign(std::size_t(ranks_), 0);
  std::vector<std::uint64_t> out(send);
  std::vector<Communicator::Transfer> t;
  for (int q = 0; q < ranks_; ++q) {
    if (q == rank_) continue;
    t.push_back({q, &out[std::size_t(q)], sizeof(std::uint64_t), true});
    t.push_back({q, &recv[std::size_t(q)], sizeof(std::uint64_t), false});
  }
  transfer(t);
}

// One all-reduce: whether some owned particle moved more than the slack, and the widest band
// a rank's stage asked for (request_band), which takes effect now.
bool Domain::due(State& s) {
  double mine[2] = {0, requested_band_};
  if (slack_ > 0 && moved(s)) mine[0] = 1;
  comm_.all_reduce(mine, 2, ReduceOp::max);
  requested_band_ = 0;
  const bool widen = mine[1] > band_;
  if (widen) band_ = mine[1];
  return mine[0] != 0 || widen;
}

// x0_ after a migration on the device, which kept the start positions there only.
void Domain::start_on_host(State& s) {
  if (x0_on_host_) return;
#ifdef FLIPFLOW_HAVE_CUDA
  const std::size_t m = s.n_owned() * std::size_t(s.dim());
  x0_.resize(m);
  if (s.real() == DType::f32) {
    std::vector<float> v(m);
    staging_->traffic->get_start(v.data(), m * sizeof(float));
    for (std::size_t i = 0; i < m; ++i) x0_[i] = double(v[i]);
  } else {
    staging_->traffic->get_start(x0_.data(), m * sizeof(double));
  }
#endif
  x0_on_host_ = true;
}

bool Domain::moved(State& s) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (staging_->traffic) {
    GhostTraffic& g = *staging_->traffic;
    g.wait_for_device();  // the last step's stages, on their own streams
    Field& pos = s.field(fields::position);
    pos.acquire(Where::device, Mode::read, g.stream());
    return g.moved_beyond(pos.device_raw(), s.real() == DType::f32, s.n_owned(), s.dim(), s.box.L, slack_);
  }
#endif
  start_on_host(s);
  return s.real() == DType::f32 ? moved_beyond<float>(s, x0_, slack_) : moved_beyond<double>(s, x0_, slack_);
}

double Domain::displacement(State& s, const std::string& field) {
  start_on_host(s);
  const std::vector<double> x = owned_values(s, field);
  const int D = s.dim();
  const PeriodicBox<double> box = PeriodicBox<double>::make(s.box.L);
  double worst = 0;
  for (std::size_t i = 0; i < s.n_owned(); ++i) worst = std::max(worst, moved_squared(x.data(), x0_.data(), i, D, box));
  worst = std::sqrt(worst);
  comm_.all_reduce(&worst, 1, ReduceOp::max);
  return worst;
}

std::vector<double> Domain::owned_values(State& s, const std::string& field) const {
  Field& pos = s.field(field);
  pos.acquire(Where::host, Mode::read);
  const std::size_t m = s.n_owned() * std::size_t(s.dim());
  std::vector<double> x(m);
  for (std::size_t i = 0; i < m; ++i) x[i] = s.real() == DType::f32 ? double(pos.host<float>()[i]) : pos.host<double>()[i];
  return x;
}


void Domain::lap(const char* phase) {
  const auto now = std::chrono::steady_clock::now();
  if (timing_) migration_phase_seconds_[phase] += std::chrono::duration<double>(now - lap_).count();
  lap_ = now;
}

void Domain::begin_step(State& s) {
  const auto t0 = std::chrono::steady_clock::now();
  lap_ = t0;
  if (due(s)) {
    timing_ = true;
    lap("test");
#ifdef FLIPFLOW_HAVE_CUDA
    if (staging_->traffic && !fill_gap_) migrate_on_device(s);
    else
#endif
      migrate_on_host(s);
    timing_ = false;
    ++migrations_;
    migration_seconds_ += seconds_since(t0);
    return;
  }
  refresh(s, refreshed_);
  step_start_seconds_ += seconds_since(t0);
}

void Domain::refresh(State& s, const std::vector<std::string>& fields) {
  if (fields.empty()) return;
  Layout lay;
  for (auto& n : fields) {
    lay.names.push_back(n);
    lay.offset.push_back(lay.bytes);
    lay.size.push_back(entry_bytes(s.field(n)));
    lay.bytes += lay.size.back();
  }
#ifdef FLIPFLOW_HAVE_CUDA
  // From the side the values are current on: the device when every field is current there (a
  // CUDA stage wrote them); else the host (a host-side stage wrote them: the Delaunay
  // correction's team loop), which leaves the host side alone current.
  bool on_device = staging_->traffic != nullptr;
  for (auto& n : fields) on_device = on_device && s.field(n).valid_on(Where::device);
  if (on_device) {
    refresh_on_device(s, lay);
    return;
  }
#endif
  auto out = std::vector<std::vector<unsigned char>>(std::size_t(ranks_)), in = out;
  std::vector<Communicator::Transfer> t;
  for (int q = 0; q < ranks_; ++q) {
    if (q == rank_) continue;
    pack(s, lay, send_[std::size_t(q)], out[std::size_t(q)]);
    in[std::size_t(q)].resize(recv_[std::size_t(q)].size() * lay.bytes);
    if (!out[std::size_t(q)].empty()) t.push_back({q, out[std::size_t(q)].data(), out[std::size_t(q)].size(), true});
    if (!in[std::size_t(q)].empty()) t.push_back({q, in[std::size_t(q)].data(), in[std::size_t(q)].size(), false});
  }
  transfer(t);
  for (std::size_t f = 0; f < lay.names.size(); ++f) {
    Field& field = s.field(lay.names[f]);
    field.acquire(Where::host, Mode::write);  // after pack's reads: the host copy is current
    auto* dst = static_cast<unsigned char*>(field.host_raw());
    const std::size_t sz = lay.size[f];
    for (int q = 0; q < ranks_; ++q) {
      const auto& idx = recv_[std::size_t(q)];
      for (std::size_t k = 0; k < idx.size(); ++k)
        std::memcpy(dst + std::size_t(idx[k]) * sz, &in[std::size_t(q)][k * lay.bytes + lay.offset[f]], sz);
    }
  }
  // The host copy alone is current now: a caller that refreshes from the host works there (the
  // Delaunay correction's loop, every iteration), and the next stage on the device copies the
  // fields once. (The first version uploaded them here, for a caller holding device pointers:
  // such a caller's fields are current on the device, and those go the device way.)
}

// The refresh on CUDA: the same records (lay) by the same lists, packed, sent and unpacked on
// the device. The device side of each field is made current and declared written (so a host
// copy made current since, by pack or by anything else, is stale again): a stage that calls
// this within its step wrote its fields on the device after the scheduler's acquire.
void Domain::refresh_on_device(State& s, const Layout& lay) {
#ifdef FLIPFLOW_HAVE_CUDA
  GhostTraffic& g = *staging_->traffic;
  g.wait_for_device();  // the stages' writes, on their own streams
  std::vector<void*> data;
  for (auto& n : lay.names) {
    Field& f = s.field(n);
    f.acquire(Where::device, Mode::readwrite, g.stream());
    data.push_back(f.device_raw());
  }
  std::vector<Communicator::Transfer> t;
  for (int q = 0; q < ranks_; ++q) {
    if (q == rank_) continue;
    const std::size_t out = send_[std::size_t(q)].size() * lay.bytes, in = recv_[std::size_t(q)].size() * lay.bytes;
    if (out) {
      void* buf = g.send_buffer(q, out);
      for (std::size_t f = 0; f < lay.names.size(); ++f) g.pack(q, data[f], lay.size[f], lay.bytes, lay.offset[f]);
      t.push_back({q, buf, out, true});
    }
    if (in) t.push_back({q, g.recv_buffer(q, in), in, false});
  }
  comm_.exchange(t, g.stream());
  for (int q = 0; q < ranks_; ++q) {
    if (q == rank_ || recv_[std::size_t(q)].empty()) continue;
    for (std::size_t f = 0; f < lay.names.size(); ++f) g.unpack(q, data[f], lay.size[f], lay.bytes, lay.offset[f]);
  }
  g.wait();  // the stages' streams do not order with this one
#else
  (void)s;
  (void)lay;
#endif
}

void Domain::gather(State& s, State* into, const std::vector<std::string>& names) {
  const Layout lay = layout_of(s, names);
  std::vector<std::uint32_t> owned(s.n_owned());
  std::iota(owned.begin(), owned.end(), 0u);
  std::vector<unsigned char> mine;
  pack(s, lay, owned, mine);
  std::vector<std::uint64_t> counts(std::size_t(ranks_), 0), incoming;
  if (rank_ != 0) counts[0] = s.n_owned();
  exchange_counts(counts, incoming);
  auto in = std::vector<std::vector<unsigned char>>(std::size_t(ranks_));
  std::vector<Communicator::Transfer> t;
  if (rank_ != 0) {
    if (!mine.empty()) t.push_back({0, mine.data(), mine.size(), true});
  } else {
    for (int q = 1; q < ranks_; ++q) {
      in[std::size_t(q)].resize(incoming[std::size_t(q)] * lay.bytes);
      if (!in[std::size_t(q)].empty()) t.push_back({q, in[std::size_t(q)].data(), in[std::size_t(q)].size(), false});
    }
  }
  transfer(t);
  if (rank_ != 0 || !into) return;
  in[0] = std::move(mine);
  for (std::size_t f = 0; f < lay.names.size(); ++f) {
    if (!into->has_field(lay.names[f])) continue;
    Field& field = into->field(lay.names[f]);
    field.acquire(Where::host, Mode::write);
    auto* dst = static_cast<unsigned char*>(field.host_raw());
    const std::size_t sz = lay.size[f];
    for (auto& rec : in)
      for (std::size_t k = 0; k < rec.size() / lay.bytes; ++k) {
        std::uint32_t id;
        std::memcpy(&id, &rec[k * lay.bytes + lay.id_offset], sizeof id);
        std::memcpy(dst + std::size_t(id) * sz, &rec[k * lay.bytes + lay.offset[f]], sz);
      }
  }
  if (s.step != 0) return;
  for (const std::string& name : not_computed_) {
    if (!into->has_field(name)) continue;
    Field& field = into->field(name);
    field.acquire(Where::host, Mode::write);
    fill_not_computed(field.host_raw(), field.dtype(), field.size());
  }
}

}  // namespace ff
