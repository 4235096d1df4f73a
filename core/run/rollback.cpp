#include "core/run/rollback.h"

#include <algorithm>
#include <cstring>
#include <sstream>

#ifdef FLIPFLOW_HAVE_CUDA
#include "core/backend/cuda/check.h"
#endif
#include "core/base/error.h"
#include "core/backend/host_copy.h"
#include "core/stage/stage.h"

namespace ff {

void copy_field_contents(Field& dst, Field& src, Where where, CUstream_st* stream) {
  // Every element is written below: a count that differs (a decomposed team's migration changed
  // the field's) needs no copy of the old contents (Field::resize would bring them to the host).
  if (dst.count() != src.count()) dst.resize_discarding(src.count());
  if (where == Where::host) {
    src.acquire(Where::host, Mode::read);
    dst.acquire(Where::host, Mode::write);
    host_copy(dst.host_raw(), src.host_raw(), src.bytes());
    return;
  }
#ifdef FLIPFLOW_HAVE_CUDA
  src.acquire(Where::device, Mode::read, stream);
  dst.acquire(Where::device, Mode::write, stream);
  if (src.bytes())
    FF_CUDA_CHECK(cudaMemcpyAsync(dst.device_raw(), src.device_raw(), src.bytes(), cudaMemcpyDeviceToDevice, stream),
                  "copying a field for a rollback snapshot");
#else
  (void)stream;
  throw RunError("device snapshot in a build without CUDA");
#endif
}

namespace {
// Where a snapshot keeps its copy of f: where the data is current, on the device for a CUDA
// run, so a snapshot never crosses the bus.
Where current_side(const Field& f) {
#ifdef FLIPFLOW_HAVE_CUDA
  return f.valid_on(Where::device) ? Where::device : Where::host;
#else
  (void)f;
  return Where::host;
#endif
}
}  // namespace

Snapshot::Snapshot(std::vector<std::string> fields, std::vector<std::string> on_demand) {
  for (auto& f : fields) entries_.push_back(Entry{std::move(f), false, false, false, Where::host, nullptr});
  for (auto& f : on_demand) entries_.push_back(Entry{std::move(f), true, false, false, Where::host, nullptr});
}

void Snapshot::copy_in(State& state, Entry& e, CUstream_st* stream) {
  Field& f = state.field(e.name);
  if (!e.copy) e.copy = std::make_unique<Field>(e.name, f.dtype(), f.components(), f.count());
  e.side = current_side(f);
  copy_field_contents(*e.copy, f, e.side, stream);
}

void Snapshot::take(State& state, CUstream_st* stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (Entry& e : entries_) {
    e.taken = e.swapped = false;
    if (!e.on_demand) copy_in(state, e, stream);
  }
}

void Snapshot::take_before_write(State& state, const std::string& field, CUstream_st* stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (Entry& e : entries_)
    if (e.on_demand && !e.taken && e.name == field) {
      copy_in(state, e, stream);
      e.taken = true;
    }
}

Field* Snapshot::take_before_overwrite(State& state, const std::string& field) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (Entry& e : entries_)
    if (e.on_demand && !e.taken && e.name == field) {
      Field& f = state.field(e.name);
      if (!e.copy) e.copy = std::make_unique<Field>(e.name, f.dtype(), f.components(), f.count());
      e.copy->resize_discarding(f.count());  // a migration changed the count: the caller writes it all
      e.side = current_side(f);
      f.swap_contents(*e.copy);
      f.mark_written(e.side);  // (stale contents: the caller writes every element next)
      e.taken = true;
      e.swapped = true;
      return e.copy.get();
    }
  return nullptr;
}

Field* Snapshot::contents_at_start(const std::string& field) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (Entry& e : entries_)
    if (e.name == field && (!e.on_demand || e.taken)) return e.copy.get();
  return nullptr;
}

void Snapshot::restore(State& state, CUstream_st* stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (Entry& e : entries_) {
    if (e.on_demand && !e.taken) continue;  // not written in this step
    Field& f = state.field(e.name);
    if (e.swapped)
      f.swap_contents(*e.copy);  // back: the copy holds what the field held before the step
    else
      copy_field_contents(f, *e.copy, e.side, stream);
    f.mark_written(e.side);
    e.taken = false;  // the retried attempt announces its writes again
    e.swapped = false;
  }
}

std::vector<std::string> Snapshot::fields() const {
  std::vector<std::string> out;
  for (const Entry& e : entries_)
    if (!e.on_demand) out.push_back(e.name);
  return out;
}

std::vector<std::string> Snapshot::on_demand_fields() const {
  std::vector<std::string> out;
  for (const Entry& e : entries_)
    if (e.on_demand) out.push_back(e.name);
  return out;
}

void StepContext::will_write(const std::string& field) const {
  if (snapshot) snapshot->take_before_write(state, field, stream);
}

Field& StepContext::will_overwrite(const std::string& field) const {
  Field* old = snapshot ? snapshot->take_before_overwrite(state, field) : nullptr;
  return old ? *old : state.field(field);
}

Field* StepContext::at_step_start(const std::string& field) const {
  if (!snapshot) return nullptr;
  Field* start = snapshot->contents_at_start(field);
  return start ? start : &state.field(field);
}

void StateImage::take(State& state, const std::vector<std::string>& skip) {
  fields_.clear();
  for (const std::string& name : state.field_names()) {
    if (std::find(skip.begin(), skip.end(), name) != skip.end()) continue;
    Field& f = state.field(name);
    f.acquire(Where::host, Mode::read);
    const auto* p = static_cast<const unsigned char*>(f.host_raw());
    fields_.push_back(FieldBytes{name, f.dtype(), f.components(), std::vector<unsigned char>(p, p + f.bytes())});
  }
  step_ = state.step;
  time_ = state.time;
  for (int k = 0; k < 3; ++k) box_[k] = state.box.L[k];
}

std::string StateImage::differences(State& state) const {
  std::ostringstream os;
  if (state.step != step_ || state.time != time_) os << "the clock (step " << state.step << ", time " << state.time
                                                     << "; before: step " << step_ << ", time " << time_ << "); ";
  for (int k = 0; k < 3; ++k)
    if (state.box.L[k] != box_[k]) os << "the box length " << k << " (" << state.box.L[k] << ", was " << box_[k] << "); ";
  for (const FieldBytes& b : fields_) {
    if (!state.has_field(b.name)) {
      os << "field '" << b.name << "' is gone; ";
      continue;
    }
    Field& f = state.field(b.name);
    if (f.bytes() != b.bytes.size()) {
      os << "field '" << b.name << "' has " << f.count() << " elements (" << f.bytes() << " bytes, was "
         << b.bytes.size() << "); ";
      continue;
    }
    f.acquire(Where::host, Mode::read);
    const auto* now = static_cast<const unsigned char*>(f.host_raw());
    if (std::memcmp(now, b.bytes.data(), b.bytes.size()) == 0) continue;
    const std::size_t scalar = dtype_size(b.dtype);
    std::size_t first = 0, differing = 0;
    for (std::size_t k = 0; k < b.bytes.size(); k += scalar)
      if (std::memcmp(now + k, b.bytes.data() + k, scalar) != 0) {
        if (!differing) first = k / scalar;
        ++differing;
      }
    os << "field '" << b.name << "' differs in " << differing << " of " << b.bytes.size() / scalar
       << " values, first at element " << first / std::size_t(b.components) << " component "
       << first % std::size_t(b.components) << "; ";
  }
  std::string out = os.str();
  if (out.size() >= 2) out.resize(out.size() - 2);
  return out;
}

double DtController::dt() const {
  double d = current_;
  // Halving is exact in binary floating point, so d stays run.dt/2^k. Stop below dt_min: the
  // caller gives up there (and a limit of 0 must not loop forever).
  while (d > limit_ && d >= min_ * (1 - 1e-12)) d /= 2;
  return d;
}

bool DtController::halve() {
  streak_ = 0;
  const double failed = dt();
  if (failed / 2 < min_ * (1 - 1e-12)) return false;
  current_ = failed / 2;
  return true;
}

bool DtController::limit_to(double dt_max) {
  limit_ = std::min(limit_, dt_max);
  return dt() >= min_ * (1 - 1e-12);
}

void DtController::accepted(double dt_taken, double limit, bool rolled_back) {
  limit_ = limit;
  if (rolled_back || dt_taken < current_ || current_ >= nominal_) return;
  if (++streak_ >= grow_after_) {
    current_ = std::min(current_ * 2, nominal_);
    streak_ = 0;
  }
}

}  // namespace ff
