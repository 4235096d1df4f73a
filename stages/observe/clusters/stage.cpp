#include "stages/observe/clusters/stage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "core/base/error.h"
#include "core/io/durable_file.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/common/mesh_check.h"
#include "stages/neighbors/list.h"

namespace ff::observe {

namespace {

const char* const axis_name[3] = {"x", "y", "z"};

template <class R>
void to_double(const Field& f, std::vector<double>& out) {
  const R* p = f.host<R>();
  out.assign(p, p + f.size());
}

void read_real(const Field& f, std::vector<double>& out) {
  if (f.dtype() == DType::f32)
    to_double<float>(f, out);
  else
    to_double<double>(f, out);
}

}  // namespace

Clusters::Clusters(ClustersParams p, RunInfo info) : p_(std::move(p)), info_(std::move(info)) {
  source_ = p_.pairs == "verlet" ? Source::verlet : p_.pairs == "delaunay" ? Source::delaunay : Source::cells;
  neighbor_ = p_.neighbor_radius > 0 ? p_.neighbor_radius : p_.bond;
  reach_ = std::max(p_.bond, neighbor_);
}

std::vector<Access> Clusters::accesses() const {
  std::vector<Access> a{{fields::position, Where::host, Mode::read},
                        {fields::diameter, Where::host, Mode::read},
                        {fields::type, Where::host, Mode::read}};
  if (source_ == Source::verlet)
    for (const char* f : {neighbors::kList, neighbors::kCount, neighbors::kPositionAtBuild})
      a.push_back({f, Where::host, Mode::read});
  if (source_ == Source::delaunay)
    for (const char* f : {delaunay::fields::halfedge, delaunay::fields::status}) a.push_back({f, Where::host, Mode::read});
  if (p_.label_field) a.push_back({cluster_label_field, Where::host, Mode::write});
  return a;
}

void Clusters::configure(State& s) {
  const std::string me = "observe.clusters: ";
  const std::size_t n = s.n();
  const int dim = s.dim();
  types_ = std::max<int>(1, int(s.species.size()));
  species_ = s.species;
  for (int t = int(species_.size()); t < types_; ++t) species_.push_back(std::to_string(t));

  // Which species take part.
  std::vector<std::uint8_t> selected(types_, p_.types.empty() ? 1 : 0);
  for (const auto& name : p_.types) {
    const auto it = std::find(species_.begin(), species_.end(), name);
    if (it == species_.end()) {
      std::string known;
      for (const auto& sp : species_) known += (known.empty() ? "" : ", ") + sp;
      throw InputError(me + "types: no species '" + name + "' (system.types has: " + known + ")");
    }
    selected[std::size_t(it - species_.begin())] = 1;
  }
  // Not an error: a trial run with fewer particles (--set system.N=...) of a pipeline is common.
  // Quiet at the default, which is more than N in small systems (tests, describe's probe).
  if (p_.sizes_layout == "wide" && p_.size_columns > ClustersParams{}.size_columns && std::uint64_t(p_.size_columns) > n)
    std::fprintf(info_.messages,
                 "flipflow: warning: observe.clusters: size_columns = %lld is more than N = %zu: the columns past n%zu "
                 "stay 0 (size_columns: %zu gives every size its own column; sizes_layout: long lists the sizes present)\n",
                 static_cast<long long>(p_.size_columns), n, n, n);
  for (const char* f : {fields::position, fields::diameter, fields::type}) s.field(f).acquire(Where::host, Mode::read);
  read_frame(s);
  for (std::size_t i = 0; i < n; ++i) {
    const int t = frame_.type[i];
    if (t < 0 || t >= types_) throw InputError(me + "particle " + std::to_string(i) + " has type " + std::to_string(t) +
                                               ", outside system.types");
    frame_.takes_part[i] = selected[std::size_t(t)];
  }
  // Diameters: the largest among the particles taking part bounds every σ_ij of interest.
  std::vector<double> pair_d, all_d;
  sigma_max_ = 0;
  for (std::size_t i = 0; i < n; ++i) {
    all_d.push_back(frame_.diameter[i]);
    if (frame_.takes_part[i]) {
      pair_d.push_back(frame_.diameter[i]);
      sigma_max_ = std::max(sigma_max_, frame_.diameter[i]);
    }
  }
  for (auto* d : {&pair_d, &all_d}) {
    std::sort(d->begin(), d->end());
    d->erase(std::unique(d->begin(), d->end()), d->end());
  }
  if (sigma_max_ <= 0) sigma_max_ = 1;
  search_ = reach_ * sigma_max_;
  double lmin = s.box.L[0];
  for (int k = 0; k < dim; ++k) lmin = std::min(lmin, s.box.L[k]);
  // (A box of no size is `pipeline describe`'s probe, never a run's: the loader checks the box.)
  if (lmin > 0 && 2 * search_ >= lmin)
    throw InputError(me + "max(bond, neighbor_radius)·σ_max = " + std::to_string(search_) +
                     " is at least half the smallest box edge (" + std::to_string(lmin) +
                     "); the minimum image would be ambiguous: lower bond or use a larger box");

  if (source_ == Source::verlet) {
    if (!s.has_field(neighbors::kList))
      throw InputError(me + "pairs: verlet needs neighbors.verlet in the step (listed before this observer)");
    Field& cut = s.field(neighbors::kCutoff);
    cut.acquire(Where::host, Mode::read);
    verlet_cutoff_ = cut.dtype() == DType::f32 ? double(cut.host<float>()[0]) : cut.host<double>()[0];
    if (verlet_cutoff_ < search_)
      throw InputError(me + "pairs: verlet: the Verlet cutoff " + std::to_string(verlet_cutoff_) +
                       " is shorter than max(bond, neighbor_radius)·σ_max = " + std::to_string(search_) +
                       ", so the list would miss bonds: raise neighbors.verlet's cutoff (with a margin for the "
                       "moves since a build) or use pairs: cells");
  }
  if (source_ == Source::delaunay) {
    if (dim != 2) throw InputError(me + "pairs: delaunay needs a 2D system (the triangulation is 2D): use cells or verlet");
    if (!s.has_field(delaunay::fields::halfedge))
      throw InputError(me + "pairs: delaunay needs the maintained triangulation (delaunay.detect_inversion, "
                            "delaunay.flip, delaunay.lawson in the step, listed before this observer)");
    gabriel_s2_ = gabriel_ratio2(reach_, pair_d, all_d);
    if (gabriel_s2_ > 1) {
      std::ostringstream os;
      os << me << "pairs: delaunay: max(bond, neighbor_radius) = " << reach_
         << " breaks the Gabriel bound b²σ_ij² ≤ σ_ik² + σ_jk² for these diameters (worst triple: b²σ_ij²/(σ_ik² + "
            "σ_jk²) = "
         << gabriel_s2_ << " > 1; equal diameters allow b ≤ √2), so a bond need not be a Delaunay edge: lower bond or "
         << "neighbor_radius, or use pairs: cells or verlet";
      throw InputError(os.str());
    }
  }
  if (p_.label_field) {
    Field& f = s.add_particle_field(cluster_label_field, DType::i32, 1);
    f.acquire(Where::host, Mode::write);
    std::fill(f.host<std::int32_t>(), f.host<std::int32_t>() + n, -1);
  }
  columns_ = {"step", "time", "clusters", "aggregates", "monomers", "largest", "largest_fraction",
              "mean_aggregate_size", "coordination", "bonds", "unlike_fraction", "percolating"};
  for (int k = 0; k < dim; ++k) columns_.push_back(std::string("percolating_") + axis_name[k]);
  for (int a = 0; a < types_; ++a)
    for (int b = a; b < types_; ++b)
      if (selected[a] && selected[b]) columns_.push_back("bonds_" + species_[a] + "_" + species_[b]);
  columns_.push_back("fallback");
}

void Clusters::read_frame(const State& s) {
  frame_.dim = s.dim();
  for (int k = 0; k < 3; ++k) frame_.L[k] = s.box.L[k];
  read_real(s.field(fields::position), frame_.x);
  read_real(s.field(fields::diameter), frame_.diameter);
  const Field& t = s.field(fields::type);
  frame_.type.assign(t.host<std::int32_t>(), t.host<std::int32_t>() + s.n());
  frame_.takes_part.resize(s.n(), 1);
}

bool Clusters::verlet_usable(const State& s) const {
  const std::size_t n = s.n();
  std::vector<double> at_build;
  read_real(s.field(neighbors::kPositionAtBuild), at_build);
  double moved2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double r2 = 0;
    for (int k = 0; k < frame_.dim; ++k) {
      double d = frame_.x[i * frame_.dim + k] - at_build[i * frame_.dim + k];
      d -= frame_.L[k] * std::rint(d / frame_.L[k]);
      r2 += d * d;
    }
    moved2 = std::max(moved2, r2);
  }
  return search_ + 2 * std::sqrt(moved2) <= verlet_cutoff_;
}

std::string Clusters::delaunay_unusable(const State& s) const {
  const std::int32_t* status = s.field(delaunay::fields::status).host<std::int32_t>();
  if (!status[delaunay::kBuilt]) return "no triangulation yet";  // step 0, before any topology stage ran
  const std::size_t n = s.n();
  const std::int32_t* he = s.field(delaunay::fields::halfedge).host<std::int32_t>();
  const double* xy = frame_.x.data();
  if (const std::size_t bad = delaunay::count_bad_triangles(he, n, xy, frame_.L[0], frame_.L[1]))
    return std::to_string(bad) + " triangles not positive";
  if (const std::size_t bad = delaunay::count_non_delaunay(he, n, xy, frame_.L[0], frame_.L[1], 1e-10))
    return std::to_string(bad) + " edges not locally Delaunay";
  // No two disks closer than the bound tolerates (the shortest Delaunay edges).
  std::size_t close = 0;
  for (std::size_t e = 0; e < delaunay::edge_count(n); ++e) {
    const std::size_t a = std::size_t(he[4 * e]), b = std::size_t(he[4 * e + 2]);
    const double sab = 0.5 * (frame_.diameter[a] + frame_.diameter[b]);
    if (distance2(frame_, a, b) < gabriel_s2_ * sab * sab) ++close;
  }
  if (close) return std::to_string(close) + " pairs overlapping more than the Gabriel bound tolerates";
  return {};
}

Outcome Clusters::run(StepContext& ctx) {
  State& s = ctx.state;
  const std::size_t n = s.n();
  read_real(s.field(fields::position), frame_.x);
  bool fallback = false;
  std::string why = "particles moved too far since the list was built for its cutoff";
  PairRows rows;
  if (source_ == Source::verlet && verlet_usable(s)) {
    rows = list_pairs(n, s.field(neighbors::kList).host<std::uint32_t>(), s.field(neighbors::kCount).host<std::uint32_t>(),
                      neighbors::list_capacity(s));
  } else if (source_ == Source::delaunay && (why = delaunay_unusable(s)).empty()) {
    rows = edge_pairs(n, s.field(delaunay::fields::halfedge).host<std::int32_t>());
  } else {
    fallback = source_ != Source::cells;
    rows = cell_pairs(frame_, search_);
  }
  // Step 0 (observers see the initial state before any topology or list stage ran) is expected.
  if (fallback && ctx.host_params.step > 0) {
    ++fallbacks_;
    if (!warned_) {
      warned_ = true;
      std::fprintf(info_.messages,
                   "flipflow: observe.clusters: step %llu: the %s pairs could not be trusted for this frame (%s); "
                   "its own cell list was used (column `fallback` of %s; not repeated)\n",
                   static_cast<unsigned long long>(ctx.host_params.step), p_.pairs.c_str(), why.c_str(),
                   p_.file.c_str());
    }
  }
  last_ = analyse_clusters(frame_, rows, p_.bond, neighbor_, p_.min_size, types_);
  const ClusterResult& r = last_;
  if (p_.label_field) {
    Field& f = s.field(cluster_label_field);
    std::copy(r.label.begin(), r.label.end(), f.host<std::int32_t>());
  }

  const double part = double(r.taking_part);
  int percolating = 0;
  for (int k = 0; k < s.dim(); ++k) percolating += r.percolates[k];
  std::vector<double> row{double(ctx.host_params.step),
                          ctx.host_params.time,
                          double(r.sizes.size()),
                          double(r.aggregates),
                          double(r.monomers),
                          double(r.largest),
                          part > 0 ? double(r.largest) / part : 0.0,
                          r.aggregates ? double(r.in_aggregates) / double(r.aggregates) : 0.0,
                          r.in_aggregates ? double(r.coordination_sum) / double(r.in_aggregates) : 0.0,
                          double(r.bonds),
                          r.bonds ? double(r.unlike_bonds) / double(r.bonds) : 0.0,
                          double(percolating)};
  for (int k = 0; k < s.dim(); ++k) row.push_back(double(r.percolates[k]));
  std::size_t c = row.size();
  for (int a = 0; a < types_; ++a)
    for (int b = a; b < types_; ++b)
      if (c < columns_.size() - 1 && columns_[c] == "bonds_" + species_[a] + "_" + species_[b]) {
        row.push_back(double(r.bonds_by_pair[std::size_t(a) * types_ + b]));
        ++c;
      }
  row.push_back(fallback ? 1.0 : 0.0);
  // Every column but step, time and fallback is a metric.
  for (std::size_t k = 2; k + 1 < columns_.size(); ++k) ctx.metrics.set(columns_[k], row[k]);
  rows_.push_back(std::move(row));

  // The sizes exactly, as (size, count) pairs: a few dozen a call, where K columns could be N.
  SizeRow sizes;
  sizes.step = double(ctx.host_params.step);
  sizes.time = ctx.host_params.time;
  std::vector<std::uint32_t> sorted = r.sizes;
  std::sort(sorted.begin(), sorted.end());
  for (std::uint32_t sz : sorted) {
    if (sizes.counts.empty() || sizes.counts.back().first != sz) sizes.counts.emplace_back(sz, 0);
    ++sizes.counts.back().second;
  }
  size_rows_.push_back(std::move(sizes));
  return Outcome::ok();
}

std::string Clusters::write_partial(const std::string& name, const std::string& table) const {
  const std::string partial = (std::filesystem::path(info_.out_dir) / name).string() + ".partial";
  std::ostringstream out;
  out << "# observe.clusters: " << frame_.dim << "D, N = " << frame_.n() << ", bond = " << p_.bond
      << ", neighbor_radius = " << neighbor_ << ", min_size = " << p_.min_size << ", pairs = " << p_.pairs;
  if (!p_.types.empty()) {
    out << ", types =";
    for (auto& t : p_.types) out << " " << t;
  }
  out << ", frames = " << rows_.size() << ", fallbacks = " << fallbacks_ << "\n" << table;
  // Replaced whole: a kill during a checkpoint leaves the previous checkpoint's file.
  io::write_text_durably(partial, out.str(), "observe.clusters");
  return partial;
}

std::string Clusters::sizes_text() const {
  std::ostringstream out;
  out.precision(17);
  if (p_.sizes_layout == "long") {  // restore_state refuses rows with a tail here
    out << "step,time,size,clusters\n";
    for (const SizeRow& row : size_rows_)
      for (const auto& [size, count] : row.counts) out << row.step << "," << row.time << "," << size << "," << count << "\n";
    return out.str();
  }
  const std::size_t columns = std::size_t(p_.size_columns);
  out << "step,time";
  for (std::size_t k = 1; k < columns; ++k) out << ",n" << k;
  out << ",n" << columns << "plus\n";
  std::vector<std::uint64_t> dense(columns);
  for (const SizeRow& row : size_rows_) {
    std::fill(dense.begin(), dense.end(), 0);
    for (const auto& [size, count] : row.counts) dense[std::size_t(std::min<std::uint64_t>(size, columns)) - 1] += count;
    dense[columns - 1] += row.tail;  // sizes from tail_from ≥ K on (restore_state)
    out << row.step << "," << row.time;
    for (std::uint64_t c : dense) out << "," << c;
    out << "\n";
  }
  return out.str();
}

// At each checkpoint too (save_state): a run killed outright (kill -9, the node lost) then
// leaves the rows of its newest checkpoint beside it, not only bytes inside the checkpoint.
std::vector<std::string> Clusters::write_partials() const {
  std::ostringstream metrics;
  for (std::size_t k = 0; k < columns_.size(); ++k) metrics << (k ? "," : "") << columns_[k];
  metrics << "\n";
  metrics.precision(17);
  for (const auto& row : rows_) {
    for (std::size_t k = 0; k < row.size(); ++k) metrics << (k ? "," : "") << row[k];
    metrics << "\n";
  }
  return {write_partial(p_.file, metrics.str()), write_partial(p_.sizes_file, sizes_text())};
}

namespace {

// Rows of doubles as one flat array and the row lengths.
void put_rows(StageState& out, const std::string& name, const std::vector<std::vector<double>>& rows) {
  std::vector<std::uint64_t> len;
  std::vector<double> flat;
  for (auto& r : rows) {
    len.push_back(r.size());
    flat.insert(flat.end(), r.begin(), r.end());
  }
  out.put(name + ".length", len);
  out.put(name, flat);
}

std::vector<std::vector<double>> get_rows(const StageState& saved, const std::string& name) {
  const auto len = saved.get_vector<std::uint64_t>(name + ".length");
  const auto flat = saved.get_vector<double>(name);
  std::vector<std::vector<double>> rows;
  std::size_t at = 0;
  for (auto l : len) {
    if (at + l > flat.size()) throw InputError("observe.clusters: the checkpoint's rows are inconsistent");
    rows.emplace_back(flat.begin() + std::ptrdiff_t(at), flat.begin() + std::ptrdiff_t(at + l));
    at += l;
  }
  return rows;
}

}  // namespace

void Clusters::save_state(StageState& out) {
  put_rows(out, "rows", rows_);
  std::vector<double> clock;
  std::vector<std::uint64_t> length, counts, tail;
  for (const SizeRow& row : size_rows_) {
    clock.insert(clock.end(), {row.step, row.time});
    length.push_back(row.counts.size());
    for (const auto& [size, count] : row.counts) counts.insert(counts.end(), {size, count});
    tail.insert(tail.end(), {row.tail_from, row.tail});
  }
  out.put("size_counts.clock", clock);
  out.put("size_counts.length", length);
  out.put("size_counts", counts);
  out.put("size_counts.tail", tail);
  out.put("fallbacks", fallbacks_);
  out.put("warned", std::uint8_t(warned_ ? 1 : 0));
  if (!info_.out_dir.empty()) write_partials();
}

void Clusters::restore_state(const StageState& saved, State&) {
  if (!saved.has("rows")) return;
  rows_ = get_rows(saved, "rows");
  size_rows_.clear();
  if (saved.has("size_counts.length")) {
    const auto clock = saved.get_vector<double>("size_counts.clock");
    const auto length = saved.get_vector<std::uint64_t>("size_counts.length");
    const auto counts = saved.get_vector<std::uint64_t>("size_counts");
    const auto tail = saved.get_vector<std::uint64_t>("size_counts.tail");
    std::uint64_t pairs = 0;
    for (std::uint64_t l : length) pairs += l;
    if (clock.size() != 2 * length.size() || tail.size() != 2 * length.size() || counts.size() != 2 * pairs)
      throw InputError("observe.clusters: the checkpoint's cluster sizes are inconsistent");
    std::size_t at = 0;
    for (std::size_t r = 0; r < length.size(); ++r) {
      SizeRow row{clock[2 * r], clock[2 * r + 1], {}, tail[2 * r], tail[2 * r + 1]};
      for (std::uint64_t k = 0; k < length[r]; ++k, at += 2) row.counts.emplace_back(counts[at], counts[at + 1]);
      size_rows_.push_back(std::move(row));
    }
  } else {
    // Before session 40 the checkpoint kept the wide rows (step, time, n1 ... nKplus): sizes
    // below K exactly, those of K or more together as the row's tail.
    for (const auto& dense : get_rows(saved, "size_rows")) {
      if (dense.size() < 4) throw InputError("observe.clusters: the checkpoint's cluster sizes are inconsistent");
      SizeRow row{dense[0], dense[1], {}, dense.size() - 2, std::uint64_t(dense.back())};
      for (std::size_t k = 2; k + 1 < dense.size(); ++k)
        if (dense[k] > 0) row.counts.emplace_back(k - 1, std::uint64_t(dense[k]));
      size_rows_.push_back(std::move(row));
    }
  }
  // A tail cannot be split: it fits only a wide file whose last column starts at or below it.
  for (const SizeRow& row : size_rows_) {
    if (row.tail == 0) continue;
    const std::string old = "the checkpoint's " + p_.sizes_file + " rows have size_columns = " +
                            std::to_string(row.tail_from) + " (a checkpoint of flipflow before session 40)";
    if (p_.sizes_layout == "long")
      throw InputError("observe.clusters: " + old +
                       " and count their clusters of that size or more together, so they cannot be written with "
                       "sizes_layout: long; resume with sizes_layout: wide, or start a new run");
    if (std::uint64_t(p_.size_columns) > row.tail_from)
      throw InputError("observe.clusters: " + old + ", fewer than size_columns = " + std::to_string(p_.size_columns) +
                       ": their clusters of that size or more are counted together, so they cannot be continued "
                       "with more columns; resume with the checkpoint's size_columns, or start a new run");
  }
  fallbacks_ = saved.get<std::uint64_t>("fallbacks");
  warned_ = saved.get<std::uint8_t>("warned") != 0;
}

void Clusters::finish(State&, bool completed) {
  if (finished_ || info_.out_dir.empty()) return;
  finished_ = true;
  const std::vector<std::string> partials = write_partials();
  const std::string names[2] = {p_.file, p_.sizes_file};
  for (int k = 0; k < 2; ++k) {
    if (!completed) {
      std::fprintf(info_.messages, "flipflow: the run did not complete; observe.clusters kept what it had at '%s'\n",
                   partials[k].c_str());
      continue;
    }
    const std::filesystem::path path = std::filesystem::path(info_.out_dir) / names[k];
    std::error_code ec;
    std::filesystem::rename(partials[k], path, ec);
    if (ec)
      throw RunError("observe.clusters: cannot rename '" + partials[k] + "' to '" + path.string() + "': " +
                     ec.message());
  }
}

}  // namespace ff::observe
