#include "stages/observe/h5md/stage.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "core/backend/not_computed.h"
#include "core/base/error.h"
#include "core/base/suggestion.h"

namespace ff::observe {

namespace {

bool is_triangle_list(const Field& f) { return f.dtype() == DType::i32 && f.components() == 3; }

std::vector<std::string> writable_field_names(const State& s) {
  std::vector<std::string> names;
  for (auto& name : s.field_names()) {
    const Field& f = s.field(name);
    if (f.count() == s.n() || is_triangle_list(f)) names.push_back(name);
  }
  return names;
}

std::string writable_fields(const State& s) {
  std::string out;
  for (auto& name : writable_field_names(s)) out += (out.empty() ? "" : ", ") + name;
  return out;
}

std::string exact(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

std::string read_text(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw RunError("observe.h5md: cannot read the pipeline file '" + file + "' to record it in the output");
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

}  // namespace

std::vector<Access> H5mdObserver::accesses() const {
  // On CUDA the frame is copied from the device asynchronously (pinned buffers, an event the
  // writer thread waits on), so the GPU never waits for HDF5 and the host never waits for
  // the copy.
  const Where where = info_.backend == Backend::cuda ? Where::device : Where::host;
  std::vector<Access> a;
  for (auto& name : p_.fields) a.push_back({name, where, Mode::read});
  if (std::find(p_.fields.begin(), p_.fields.end(), fields::type) == p_.fields.end())
    a.push_back({fields::type, Where::host, Mode::read});  // /particles/all/species
  return a;
}

void H5mdObserver::configure(State& state) {
  connectivity_.clear();
  std::set<std::string> seen;
  for (auto& name : p_.fields) {
    if (!seen.insert(name).second) throw InputError("observe.h5md: field '" + name + "' is listed twice in `fields`");
    if (name == "box" || name == "species")
      throw InputError("observe.h5md: '" + name + "' is written anyway (/particles/all/" + name +
                       "); remove it from `fields`");
    if (!state.has_field(name))
      throw InputError("observe.h5md: there is no field '" + name + "' to write" +
                       suggestion(name, writable_field_names(state)) + " (fields available: " + writable_fields(state) +
                       ")");
    const Field& f = state.field(name);
    if (f.count() != state.n() && !is_triangle_list(f))
      throw InputError("observe.h5md: field '" + name + "' has " + std::to_string(f.count()) +
                       " elements, neither one per particle (" + std::to_string(state.n()) +
                       ") nor a triangle list (3 x i32); fields available: " + writable_fields(state));
    connectivity_.push_back(f.count() != state.n());
  }
  if (p_.frames_every > 0 && p_.fields.empty())
    throw InputError("observe.h5md: frames_every: " + std::to_string(p_.frames_every) +
                     " with fields: [] has no frames to space out; remove frames_every (the observables are written "
                     "at every step this observer runs)");
  if (p_.frames_every > 0 && p_.layout == "mdanalysis")
    throw InputError("observe.h5md: frames_every: " + std::to_string(p_.frames_every) +
                     " with layout: mdanalysis: that layout gives the observables one row per frame, as MDAnalysis "
                     "reads them; write the finer time series to a second observe.h5md with fields: [] and its own "
                     "file:");
}

std::string H5mdObserver::path() const { return (std::filesystem::path(info_.out_dir) / p_.file).string(); }

void H5mdObserver::open(const State& state) {
  H5mdHeader h;
  h.dim = state.dim();
  h.readers_layout = p_.layout == "mdanalysis";
  for (int k = 0; k < 3; ++k) h.edges[k] = state.box.L[k];
  const RunRecord& rec = info_.record;
  if (!rec.pipeline_text.empty()) h.pipeline_text = rec.pipeline_text;
  else if (!info_.pipeline_file.empty()) h.pipeline_text = read_text(info_.pipeline_file);
  h.run_attributes = {{"pipeline_file", info_.pipeline_file},
                      {"precision", to_string(state.precision())},
                      {"backend", to_string(info_.backend)},
                      {"seed", std::to_string(info_.seed)},
                      {"steps", std::to_string(info_.steps)},
                      {"dt", exact(info_.dt)},
                      {"stage_id", info_.stage_id}};
  // A file begun by a resumed run (restore_state found neither it nor its .partial): it starts
  // at the checkpoint, and says so.
  if (!rec.resumed_from.empty() && starts_at_resume_) {
    h.run_attributes.push_back({"resumed_from", rec.resumed_from});
    h.run_attributes.push_back({"first_step", std::to_string(rec.resume_step)});
  }
  // What produced the run (version, commit, device, ...), unless named above already.
  for (auto& kv : rec.attributes) {
    bool named = false;
    for (auto& have : h.run_attributes) named = named || have.first == kv.first;
    if (!named) h.run_attributes.push_back(kv);
  }
  // The pipeline as it ran: after --set (effective_pipeline) and with every default filled in
  // (resolved), so a run made with overrides can be reproduced from its output.
  if (!rec.effective_pipeline.empty()) h.texts.emplace_back("effective_pipeline", rec.effective_pipeline);
  if (!rec.resolved.empty()) h.texts.emplace_back("resolved", rec.resolved);
  std::string overrides;
  for (auto& o : rec.overrides) overrides += o + "\n";
  h.texts.emplace_back("overrides", overrides);
  auto w = std::make_unique<H5mdWriter>(path(), h);
  w->report_to(info_.messages);
  w->write_species(state.field(fields::type).host<std::int32_t>(), state.n(), state.species);
  for (std::size_t i = 0; i < p_.fields.size(); ++i) {
    if (connectivity_[i]) continue;  // created with its first frame
    const Field& f = state.field(p_.fields[i]);
    w->add_particle_element(f.name(), f.dtype(), f.count(), f.components());
  }
  writer_ = std::make_unique<AsyncFrameWriter>(std::move(w), queue_depth);
}

bool H5mdObserver::writes_fields_at(std::uint64_t step) {
  if (p_.frames_every <= 0) return true;
  const auto every = std::uint64_t(p_.frames_every);
  // The runs' spacing comes from the entry's schedule, which the stage does not see: a spacing
  // that does not divide frames_every skips frames the user asked for, so it is said once.
  if (last_run_step_ && step > *last_run_step_ && !warned_frames_every_) {
    const std::uint64_t gap = step - *last_run_step_;
    if (every % gap != 0) {
      warned_frames_every_ = true;
      std::fprintf(info_.messages,
                   "flipflow: warning: step '%s' (observe.h5md): frames_every: %llu is not a multiple of the %llu "
                   "steps between its runs at steps %llu and %llu, so frames are written only where both meet; give "
                   "it an `every:` that divides %llu\n",
                   info_.stage_id.c_str(), static_cast<unsigned long long>(every),
                   static_cast<unsigned long long>(gap), static_cast<unsigned long long>(*last_run_step_),
                   static_cast<unsigned long long>(step), static_cast<unsigned long long>(every));
    }
  }
  last_run_step_ = step;
  return step % every == 0;
}

void H5mdObserver::copy_frame(StepContext& ctx, Frame& frame, bool with_fields) {
  // Observers run on an accepted state: host_params.step and .time are its clock (0 = the start).
  frame.step = std::int64_t(ctx.host_params.step);
  frame.time = ctx.host_params.time;
  frame.with_fields = with_fields;
  frame.observables.clear();
  if (with_fields) copy_fields(ctx, frame);
  if (!p_.observables) return;
  frame.observables.push_back({"dt", frame.step, frame.time, ctx.stats.dt});
  frame.observables.push_back({"rollbacks", frame.step, frame.time, double(ctx.stats.rollbacks)});
  append_metrics(ctx.stats, frame);
}

void H5mdObserver::append_metrics(const RunStats& stats, Frame& frame) {
  for (auto& [name, value] : stats.metrics) {
    auto stamp = stats.metric_stamps.find(name);
    if (stamp == stats.metric_stamps.end()) {  // (a metric without a stamp: a hand-made RunStats)
      frame.observables.push_back({name, frame.step, frame.time, value});
      continue;
    }
    // A value not reported again since its last row is not new: written once, at the step it was
    // measured (MDAnalysis' layout: at the frame's, since its rows are the frames).
    const std::uint64_t at = stamp->second.step;
    auto written = metric_written_at_.find(name);
    if (written != metric_written_at_.end() && at <= written->second) continue;
    if (written != metric_written_at_.end() && stamp->second.only_in_observables) note_lost_reports(name, stamp->second, written->second);
    metric_written_at_[name] = at;
    if (stamp->second.only_in_observables) metric_reports_written_[name] = stamp->second.reports;
    if (p_.layout == "mdanalysis") frame.observables.push_back({name, frame.step, frame.time, value});
    else frame.observables.push_back({name, std::int64_t(at), stamp->second.time, value});
  }
}

void H5mdObserver::note_lost_reports(const std::string& name, const RunStats::Stamp& stamp, std::uint64_t previous_row) {
  auto before = metric_reports_written_.find(name);
  if (warned_lost_reports_ || before == metric_reports_written_.end() || stamp.reports <= before->second + 1) return;
  warned_lost_reports_ = true;
  const std::uint64_t lost = stamp.reports - before->second - 1;
  std::fprintf(info_.messages,
               "flipflow: warning: step '%s' (observe.h5md) writes '%s' only when it runs itself: %llu value%s "
               "reported between its rows at steps %llu and %llu %s not in '%s'. Run it as often as the observers "
               "whose metrics it writes, and space its frames with frames_every\n",
               info_.stage_id.c_str(), name.c_str(), static_cast<unsigned long long>(lost), lost == 1 ? "" : "s",
               static_cast<unsigned long long>(previous_row), static_cast<unsigned long long>(stamp.step),
               lost == 1 ? "is" : "are", p_.file.c_str());
}

void H5mdObserver::copy_fields(StepContext& ctx, Frame& frame) const {
  frame.fields.resize(p_.fields.size());
  for (std::size_t i = 0; i < p_.fields.size(); ++i) {
    Field& f = ctx.state.field(p_.fields[i]);
    FieldFrame& out = frame.fields[i];
    out.name = f.name();
    out.connectivity = connectivity_[i];
    out.count = f.count();
    if (!out.connectivity && out.count != ctx.state.n())
      throw RunError("observe.h5md: field '" + out.name + "' was written per particle but now has " +
                     std::to_string(out.count) + " elements");
    const bool on_device = info_.backend == Backend::cuda;
    if (out.bytes.size() == 0) out.bytes = HostBuffer(on_device);
    out.bytes.resize(f.bytes());
    // The initial frame of a field the steps compute: NaN, not its allocation's zeros (not_computed.h;
    // integer fields keep their zeros).
    if (ctx.host_params.step == 0 && not_computed(f)) {
      fill_not_computed(out.bytes.data(), f.dtype(), f.size());
      continue;
    }
    if (on_device) copy_device_to_host_async(out.bytes.data(), f.device_raw(), f.bytes(), ctx.stream);
    else if (f.bytes()) std::memcpy(out.bytes.data(), f.host_raw(), f.bytes());
  }
  if (info_.backend == Backend::cuda) frame.ready.record(ctx.stream);
}

Outcome H5mdObserver::run(StepContext& ctx) {
  if (!writer_) open(ctx.state);
  const bool with_fields = writes_fields_at(ctx.host_params.step);
  if (!with_fields && !p_.observables) return Outcome::ok();  // nothing to write at this step
  Frame frame = writer_->take();
  copy_frame(ctx, frame, with_fields);
  writer_->submit(std::move(frame));
  return Outcome::ok();
}

void H5mdObserver::save_state(StageState& out) {
  drain();
  // Whether the file was begun: a schedule whose first frame comes after the checkpoint has none
  // yet, and its continuation must not warn of a lost one.
  out.put("file_begun", std::uint8_t(writer_ ? 1 : 0));
}

void H5mdObserver::restore_state(const StageState& saved, State& state) {
  const RunRecord& rec = info_.record;
  std::string overrides;
  for (auto& o : rec.overrides) overrides += o + "\n";
  const std::vector<std::pair<std::string, std::string>> history = {
      {"step", std::to_string(state.step)},
      {"time", exact(state.time)},
      {"checkpoint", rec.resumed_from},
      {"steps", std::to_string(info_.steps)},
      {"changes", rec.changes},
      {"overrides", overrides},
      {"effective_pipeline", rec.effective_pipeline}};
  auto w = H5mdWriter::reopen(path(), std::int64_t(state.step), history);
  // (checkpoints written before file_begun was saved: assume the file was begun, as they all were
  // but for late first frames)
  const bool begun = !saved.has("file_begun") || saved.get<std::uint8_t>("file_begun") != 0;
  if (!w && !begun) return;  // its first frame is still to come: a whole file, nothing to say
  if (!w) {
    starts_at_resume_ = true;
    // Neither the file nor its .partial: moved away (a damaged file, as reopen's error advises)
    // or lost. open() starts a new one at the next frame, recording where it starts.
    std::fprintf(info_.messages,
                 "flipflow: warning: observe.h5md: neither '%s' nor its .partial exists; a new file starts at step "
                 "%llu (the frames before the checkpoint are not in it: its /parameters attributes resumed_from and "
                 "first_step say so)\n",
                 path().c_str(), static_cast<unsigned long long>(state.step));
    return;
  }
  w->report_to(info_.messages);
  for (std::size_t i = 0; i < p_.fields.size(); ++i) {
    if (connectivity_[i] || w->has_particle_element(p_.fields[i])) continue;
    const Field& f = state.field(p_.fields[i]);
    w->add_particle_element(f.name(), f.dtype(), f.count(), f.components());
  }
  writer_ = std::make_unique<AsyncFrameWriter>(std::move(w), queue_depth);
}

void H5mdObserver::drain() {
  if (writer_) writer_->drain();
}

void H5mdObserver::finish(State& state, bool completed) {
  if (finished_) return;
  finished_ = true;
  if (!writer_ && !completed) return;  // nothing was written
  if (!writer_) open(state);           // a completed run leaves its file, even without frames
  std::unique_ptr<AsyncFrameWriter> w = std::move(writer_);
  try {
    w->close(completed);
  } catch (const std::exception& e) {
    if (completed) throw;
    std::fprintf(info_.messages, "flipflow: observe.h5md: %s\n", e.what());  // the run already failed
  }
}

}  // namespace ff::observe
