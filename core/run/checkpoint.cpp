#include "core/run/checkpoint.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "core/base/error.h"
#include "core/base/version.h"

namespace fs = std::filesystem;

namespace ff {

namespace {

// Field names and stage ids become HDF5 path components: '/' (and '%') are escaped.
std::string encode(const std::string& name) {
  std::string out;
  for (char c : name) {
    if (c == '/') out += "%2F";
    else if (c == '%') out += "%25";
    else out += c;
  }
  return out;
}

std::string decode(const std::string& name) {
  std::string out;
  for (std::size_t i = 0; i < name.size(); ++i) {
    if (name.compare(i, 3, "%2F") == 0) {
      out += '/';
      i += 2;
    } else if (name.compare(i, 3, "%25") == 0) {
      out += '%';
      i += 2;
    } else {
      out += name[i];
    }
  }
  return out;
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string out;
  for (auto& l : lines) out += l + "\n";
  return out;
}

// A text as one line: '\\' and newlines as "\\\\" and "\\n"; unescape_newlines undoes it.
std::string escape_newlines(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '\\' ? std::string("\\\\") : c == '\n' ? std::string("\\n") : std::string(1, c);
  return out;
}

std::string unescape_newlines(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '\\' && i + 1 < s.size()) {
      out += s[i + 1] == 'n' ? '\n' : s[i + 1];
      ++i;
    } else {
      out += s[i];
    }
  }
  return out;
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// "key = value" lines -> map (the first " = " splits: values may contain it, keys do not).
std::map<std::string, std::string> key_values(const std::vector<std::string>& lines) {
  std::map<std::string, std::string> m;
  for (auto& l : lines) {
    const auto eq = l.find(" = ");
    if (eq == std::string::npos) m[l] = "";
    else m[l.substr(0, eq)] = l.substr(eq + 3);
  }
  return m;
}

std::string exact(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

bool parse_checkpoint_name(const std::string& name, std::uint64_t& step) {
  // checkpoint-<12 digits>.h5
  if (name.size() != 11 + 12 + 3 || name.compare(0, 11, "checkpoint-") != 0 || name.compare(23, 3, ".h5") != 0)
    return false;
  step = 0;
  for (int k = 11; k < 23; ++k) {
    if (name[k] < '0' || name[k] > '9') return false;
    step = step * 10 + std::uint64_t(name[k] - '0');
  }
  return true;
}

// The checkpoint files of a directory, newest (highest step) first.
std::vector<std::pair<std::uint64_t, fs::path>> checkpoints_in(const fs::path& dir) {
  std::vector<std::pair<std::uint64_t, fs::path>> out;
  std::error_code ec;
  for (auto& e : fs::directory_iterator(dir, ec)) {
    std::uint64_t step;
    if (e.is_regular_file() && parse_checkpoint_name(e.path().filename().string(), step)) out.push_back({step, e.path()});
  }
  std::sort(out.begin(), out.end(), [](auto& a, auto& b) { return a.first > b.first; });
  return out;
}

void load_field(Field& f, const CheckpointEntry& e, const std::string& name) {
  if (e.text || e.dtype != f.dtype() || e.shape.size() != 2 || e.shape[1] != std::uint64_t(f.components()))
    throw InputError("cannot resume: field '" + name + "' is " + to_string(f.dtype()) + " x " +
                     std::to_string(f.components()) + " in this pipeline but another type or shape in the checkpoint");
  const std::size_t count = std::size_t(e.shape[0]);
  if (f.count() != count) f.resize(count);
  f.acquire(Where::host, Mode::write);
  if (!e.bytes.empty()) std::memcpy(f.host_raw(), e.bytes.data(), e.bytes.size());
}

}  // namespace

std::string checkpoint_file_name(std::uint64_t step) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "checkpoint-%012llu.h5", static_cast<unsigned long long>(step));
  return buf;
}

std::vector<std::string> pipeline_structure(const PipelineSpec& spec) {
  std::vector<std::string> out;
  out.push_back("system.dimensions = " + std::to_string(spec.system.dimensions));
  out.push_back("system.N = " + std::to_string(spec.system.N));
  out.push_back(std::string("run.precision = ") + (spec.run.precision == Precision::f32 ? "float" : "double"));
  std::string types;
  for (auto& t : spec.system.types) types += (types.empty() ? "" : ", ") + t.name;
  out.push_back("system.types = [" + types + "]");
  out.push_back("stages = " + std::to_string(spec.step.size()));
  for (std::size_t i = 0; i < spec.step.size(); ++i)
    out.push_back("step[" + std::to_string(i) + "] = " + spec.step[i].stage + " (id " + spec.step[i].id + ")");
  return out;
}

std::vector<std::string> resolved_parameters(const PipelineSpec& spec) {
  std::vector<std::string> out;
  const SystemSpec& sys = spec.system;
  if (sys.box.empty()) out.push_back("system.packing_fraction = " + exact(sys.packing_fraction));
  else {
    std::string b;
    for (double x : sys.box) b += (b.empty() ? "" : ", ") + exact(x);
    out.push_back("system.box = [" + b + "]");
  }
  out.push_back("system.sigma = " + exact(sys.sigma));
  out.push_back("system.init = " + (sys.init == "from" ? "{from: " + sys.init_from + ", frame: " +
                                                             std::to_string(sys.init_frame) + "}"
                                                       : sys.init));
  for (auto& t : sys.types)
    out.push_back("system.types." + t.name + " = {fraction: " + exact(t.fraction) + ", diameter: " + exact(t.diameter) +
                  "}");
  out.push_back("run.dt = " + exact(spec.run.dt));
  out.push_back("run.dt_min = " + exact(spec.run.dt_min));
  out.push_back("run.dt_grow_after = " + std::to_string(spec.run.dt_grow_after));
  out.push_back("run.seed = " + std::to_string(spec.run.seed));
  for (auto& e : spec.step) {
    const std::string at = "step." + e.id + ".";
    const std::string when = e.schedule.text();
    out.push_back(at + "schedule = " + (when.empty() ? "every step" : when));
    if (e.after_given) {
      std::string a;
      for (auto& x : e.after) a += (a.empty() ? "" : ", ") + x;
      out.push_back(at + "after = [" + a + "]");
    }
    for (auto& [key, value] : e.params.all()) out.push_back(at + key + " = " + format_value(value));
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---- writing ----------------------------------------------------------------------------

Checkpointer::Checkpointer(Simulation& sim, std::string dir, std::uint64_t every, std::uint64_t keep, RunRecord record,
                           std::string history)
    : sim_(sim), dir_(std::move(dir)), every_(every), keep_(std::max<std::uint64_t>(keep, 1)),
      record_(std::move(record)), history_(std::move(history)) {}

void Checkpointer::after_step() {
  const std::uint64_t step = sim_.state().step;
  if (every_ > 0 && step % every_ == 0) write();
}

std::string Checkpointer::newest() const {
  return written_ ? (fs::path(dir_) / checkpoint_file_name(last_step_)).string() : std::string();
}

std::string Checkpointer::write() {
  State& s = sim_.state();
  const fs::path path = fs::path(dir_) / checkpoint_file_name(s.step);
  if (last_step_ == s.step) return path.string();
  sim_.synchronize();
  const auto t0 = std::chrono::steady_clock::now();
  CheckpointData d;
  // Stage states first: an observer makes its files durable here, so the checkpoint never
  // claims frames its files do not hold.
  for (auto& slot : sim_.slots()) {
    StageState st;
    slot.stage->save_state(st);
    for (auto& [name, bytes] : st.all())
      d.put_array("stages/" + encode(slot.info.stage_id) + "/" + encode(name), DType::u8, {bytes.size()},
                  bytes.data(), bytes.size());
  }
  const std::vector<std::string> scratch = sim_.scratch_fields();
  for (auto& name : s.field_names()) {
    if (std::find(scratch.begin(), scratch.end(), name) != scratch.end()) continue;
    Field& f = s.field(name);
    f.acquire(Where::host, Mode::read);
    d.put_array("fields/" + encode(name), f.dtype(), {f.count(), std::uint64_t(f.components())}, f.host_raw(),
                f.bytes());
  }
  d.put_u64("clock/step", s.step);
  d.put_f64("clock/time", s.time);
  d.put_array("box/L", DType::f64, {3}, s.box.L, sizeof s.box.L);
  d.put_text("species/names", join_lines(s.species));
  d.put_array("species/diameter", DType::f64, {s.species_diameter.size()}, s.species_diameter.data(),
              s.species_diameter.size() * sizeof(double));

  const DtController& dt = sim_.dt_controller();
  d.put_f64("dt/current", dt.current());
  d.put_u64("dt/streak", dt.streak());
  d.put_f64("dt/limit", dt.limit());
  d.put_f64("dt/nominal", dt.nominal());
  d.put_f64("dt/min", dt.min());
  d.put_u64("dt/grow_after", sim_.spec().run.dt_grow_after);

  const RunStats& st = sim_.run_stats();
  d.put_u64("stats/rollbacks", st.rollbacks);
  d.put_u64("stats/step_rollbacks", st.step_rollbacks);
  d.put_u64("stats/dt_limits", st.dt_limits);
  d.put_u64("stats/step_dt_limits", st.step_dt_limits);
  d.put_f64("stats/dt_limit", st.dt_limit);
  d.put_f64("stats/dt", st.dt);
  std::vector<std::string> names;
  std::vector<double> values;
  for (auto& [k, v] : st.metrics) {
    names.push_back(k);
    values.push_back(v);
  }
  d.put_text("stats/metric_names", join_lines(names));
  d.put_array("stats/metric_values", DType::f64, {values.size()}, values.data(), values.size() * sizeof(double));
  // When each was reported (RunStats::metric_stamps), so a continued run's writer knows them as old.
  std::vector<std::uint64_t> stamp_steps, stamp_reports;
  std::vector<double> stamp_times;
  std::vector<std::uint8_t> stamp_observer;
  for (auto& name : names) {
    auto it = st.metric_stamps.find(name);
    const RunStats::Stamp stamp = it == st.metric_stamps.end() ? RunStats::Stamp{} : it->second;
    stamp_steps.push_back(stamp.step);
    stamp_times.push_back(stamp.time);
    stamp_reports.push_back(stamp.reports);
    stamp_observer.push_back(stamp.only_in_observables ? 1 : 0);
  }
  d.put_array("stats/metric_steps", DType::u64, {stamp_steps.size()}, stamp_steps.data(),
              stamp_steps.size() * sizeof(std::uint64_t));
  d.put_array("stats/metric_times", DType::f64, {stamp_times.size()}, stamp_times.data(),
              stamp_times.size() * sizeof(double));
  d.put_array("stats/metric_reports", DType::u64, {stamp_reports.size()}, stamp_reports.data(),
              stamp_reports.size() * sizeof(std::uint64_t));
  d.put_array("stats/metric_only_in_observables", DType::u8, {stamp_observer.size()}, stamp_observer.data(),
              stamp_observer.size());

  d.put_text("pipeline/text", record_.pipeline_text);
  d.put_text("pipeline/effective", record_.effective_pipeline);
  std::vector<std::string> one_line_each;  // (a --set value may span lines: YAML's flow maps)
  for (auto& o : record_.overrides) one_line_each.push_back(escape_newlines(o));
  d.put_text("pipeline/overrides", join_lines(one_line_each));
  d.put_text("pipeline/file", sim_.spec().file);
  d.put_text("pipeline/resolved", join_lines(resolved_parameters(sim_.spec())));
  d.put_text("pipeline/structure", join_lines(pipeline_structure(sim_.spec())));
  d.put_u64("meta/dim", std::uint64_t(s.dim()));
  d.put_u64("meta/n", s.n());
  d.put_text("meta/precision", to_string(s.precision()));
  d.put_text("meta/version", FF_VERSION_STRING);
  for (auto& [k, v] : record_.attributes) d.put_text("meta/run/" + encode(k), v);
  d.put_text("meta/history", history_);

  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw RunError("cannot create the checkpoint directory '" + dir_ + "': " + ec.message());
  write_checkpoint_file(path.string(), d);
  last_step_ = s.step;
  ++written_;
  prune();
  write_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::error_code size_ec;
  const std::uintmax_t bytes = fs::file_size(path, size_ec);
  last_bytes_ = size_ec ? 0 : std::uint64_t(bytes);  // (only reported)
  return path.string();
}

void Checkpointer::prune() const {
  auto files = checkpoints_in(dir_);
  for (std::size_t k = keep_; k < files.size(); ++k) {
    std::error_code ec;
    fs::remove(files[k].second, ec);
  }
}

std::vector<std::pair<std::uint64_t, std::string>> checkpoint_files(const std::string& dir) {
  std::vector<std::pair<std::uint64_t, std::string>> out;
  for (auto& [step, path] : checkpoints_in(dir)) out.push_back({step, path.string()});
  return out;
}

// ---- resuming ---------------------------------------------------------------------------

ResumePoint find_resume_point(const std::string& where) {
  ResumePoint rp;
  if (fs::is_regular_file(where)) {
    rp.path = where;
    rp.data = read_checkpoint_file(where);
    return rp;
  }
  if (!fs::is_directory(where))
    throw InputError("--resume: '" + where + "' is neither a checkpoint file nor an output directory");
  const auto files = checkpoints_in(where);
  if (files.empty())
    throw InputError("--resume: no checkpoint in '" + where +
                     "' (runs write them with run: {checkpoint: {every: K}}, at their end, and when stopped by "
                     "SIGINT or SIGTERM)");
  for (auto& [step, path] : files) {
    try {
      rp.path = path.string();
      rp.data = read_checkpoint_file(rp.path);
      return rp;
    } catch (const InputError& e) {
      const fs::path bad = path.string() + ".invalid";
      std::error_code ec;
      fs::rename(path, bad, ec);
      rp.skipped.push_back(std::string(e.what()) + (ec ? "" : " (renamed to " + bad.filename().string() + ")"));
    }
  }
  std::string why;
  for (auto& s : rp.skipped) why += "\n  " + s;
  throw InputError("--resume: no valid checkpoint in '" + where + "':" + why);
}

PipelineChanges compare_with_checkpoint(const CheckpointData& data, const PipelineSpec& spec) {
  PipelineChanges c;
  auto diff = [](const std::map<std::string, std::string>& was, const std::map<std::string, std::string>& now,
                 std::vector<std::string>& out, bool structure) {
    std::set<std::string> keys;
    for (auto& kv : was) keys.insert(kv.first);
    for (auto& kv : now) keys.insert(kv.first);
    for (auto& k : keys) {
      auto a = was.find(k), b = now.find(k);
      const std::string va = a == was.end() ? "(none)" : a->second, vb = b == now.end() ? "(none)" : b->second;
      if (va == vb) continue;
      out.push_back(structure ? k + ": the checkpoint has " + va + ", the pipeline " + vb : k + ": " + va + " -> " + vb);
    }
  };
  diff(key_values(split_lines(data.text("pipeline/structure"))), key_values(pipeline_structure(spec)), c.structure,
       true);
  diff(key_values(split_lines(data.text("pipeline/resolved"))), key_values(resolved_parameters(spec)), c.parameters,
       false);
  return c;
}

std::unique_ptr<State> state_from_checkpoint(const CheckpointData& data) {
  const int dim = int(data.u64("meta/dim"));
  const Precision precision = data.text("meta/precision") == to_string(Precision::f32) ? Precision::f32 : Precision::f64;
  auto s = std::make_unique<State>(dim, precision, std::size_t(data.u64("meta/n")));
  s->box.dim = dim;
  std::memcpy(s->box.L, data.at("box/L").bytes.data(), sizeof s->box.L);
  s->species = split_lines(data.text("species/names"));
  const auto& sd = data.at("species/diameter");
  s->species_diameter.resize(sd.bytes.size() / sizeof(double));
  if (!sd.bytes.empty()) std::memcpy(s->species_diameter.data(), sd.bytes.data(), sd.bytes.size());
  for (const char* name : {fields::position, fields::image, fields::type, fields::diameter}) {
    const CheckpointEntry& e = data.at(std::string("fields/") + name);
    Field& f = s->add_field(name, e.dtype, int(e.shape.at(1)), std::size_t(e.shape.at(0)));
    load_field(f, e, name);
  }
  s->step = data.u64("clock/step");
  s->time = data.f64("clock/time");
  return s;
}

void restore_checkpoint(Simulation& sim, const CheckpointData& data) {
  State& s = sim.state();
  std::set<std::string> saved;
  for (auto& f : data.children("fields")) saved.insert(decode(f));
  const std::vector<std::string> scratch = sim.scratch_fields();
  for (auto& name : s.field_names())
    if (!saved.count(name) && std::find(scratch.begin(), scratch.end(), name) == scratch.end())
      throw InputError("cannot resume: the pipeline makes the field '" + name +
                       "', which the checkpoint does not have (the stages differ)");
  for (auto& name : saved)
    if (!s.has_field(name)) {
      // A per-particle field no stage makes came with the initial state (an orientation read by
      // system.init.from): it comes back the same way.
      const CheckpointEntry& e = data.at("fields/" + encode(name));
      if (e.text || e.shape.size() != 2 || e.shape[0] != s.n())
        throw InputError("cannot resume: the checkpoint has the field '" + name +
                         "', which no stage of this pipeline makes (the stages differ)");
      s.add_field(name, e.dtype, int(e.shape[1]), s.n());
    }
  for (auto& name : saved) load_field(s.field(name), data.at("fields/" + encode(name)), name);
  s.step = data.u64("clock/step");
  s.time = data.f64("clock/time");
  std::memcpy(s.box.L, data.at("box/L").bytes.data(), sizeof s.box.L);

  // Δt: the controller's current value and streak continue; a changed nominal Δt (allowed with
  // --allow-changes) caps the current one.
  DtController& dt = sim.dt_controller();
  const double saved_nominal = data.f64("dt/nominal"), saved_current = data.f64("dt/current");
  const double current = saved_nominal == dt.nominal() ? saved_current
                         : saved_current >= saved_nominal ? dt.nominal()
                                                          : std::min(saved_current, dt.nominal());
  dt.set(current, data.u64("dt/streak"), data.f64("dt/limit"));

  RunStats& st = sim.run_stats();
  st.rollbacks = data.u64("stats/rollbacks");
  st.step_rollbacks = data.u64("stats/step_rollbacks");
  st.dt_limits = data.u64("stats/dt_limits");
  st.step_dt_limits = data.u64("stats/step_dt_limits");
  st.dt_limit = data.f64("stats/dt_limit");
  st.dt = data.f64("stats/dt");
  st.metrics.clear();
  const auto names = split_lines(data.text("stats/metric_names"));
  const auto& values = data.at("stats/metric_values");
  if (values.bytes.size() != names.size() * sizeof(double))
    throw InputError("cannot resume: the checkpoint's metrics are inconsistent (" + std::to_string(names.size()) +
                     " names)");
  for (std::size_t k = 0; k < names.size(); ++k) {
    double v;
    std::memcpy(&v, values.bytes.data() + k * sizeof(double), sizeof(double));
    st.metrics[names[k]] = v;
  }
  // (checkpoints written before the stamps were saved have none: their metrics count as reported
  // at the checkpoint's step, which a continued file already holds)
  st.metric_stamps.clear();
  const bool stamped = data.has("stats/metric_steps") && data.has("stats/metric_times") &&
                       data.at("stats/metric_steps").bytes.size() == names.size() * sizeof(std::uint64_t) &&
                       data.at("stats/metric_times").bytes.size() == names.size() * sizeof(double);
  for (std::size_t k = 0; k < names.size(); ++k) {
    RunStats::Stamp stamp{sim.state().step, sim.state().time};
    if (stamped) {
      std::memcpy(&stamp.step, data.at("stats/metric_steps").bytes.data() + k * sizeof(std::uint64_t),
                  sizeof(std::uint64_t));
      std::memcpy(&stamp.time, data.at("stats/metric_times").bytes.data() + k * sizeof(double), sizeof(double));
    }
    if (stamped && data.has("stats/metric_reports") && data.has("stats/metric_only_in_observables") &&
        data.at("stats/metric_reports").bytes.size() == names.size() * sizeof(std::uint64_t) &&
        data.at("stats/metric_only_in_observables").bytes.size() == names.size()) {
      std::memcpy(&stamp.reports, data.at("stats/metric_reports").bytes.data() + k * sizeof(std::uint64_t),
                  sizeof(std::uint64_t));
      stamp.only_in_observables = data.at("stats/metric_only_in_observables").bytes[k] != 0;
    }
    st.metric_stamps[names[k]] = stamp;
  }

  for (auto& slot : sim.slots()) {
    StageState saved_state;
    const std::string group = "stages/" + encode(slot.info.stage_id);
    for (auto& blob : data.children(group)) saved_state.put_bytes(decode(blob), data.at(group + "/" + blob).bytes);
    try {
      slot.stage->restore_state(saved_state, s);
    } catch (const std::runtime_error& e) {
      if (dynamic_cast<const InputError*>(&e) || dynamic_cast<const RunError*>(&e)) throw;
      throw InputError("cannot resume: stage '" + slot.info.stage_id + "': " + e.what());
    }
  }
  // Frame 0 is observed with the first step; a checkpoint at step 0 (a signal before it) has not.
  if (s.step > 0) sim.set_observed_initial();
}

std::string checkpoint_history(const CheckpointData& data) {
  return data.has("meta/history") ? data.text("meta/history") : "";
}

std::vector<std::string> checkpoint_overrides(const CheckpointData& data) {
  std::vector<std::string> out;
  if (data.has("pipeline/overrides"))
    for (auto& line : split_lines(data.text("pipeline/overrides"))) out.push_back(unescape_newlines(line));
  return out;
}

}  // namespace ff
