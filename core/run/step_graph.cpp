#include "core/run/step_graph.h"

#include <map>
#include <stdexcept>
#include <variant>
#include <sstream>

#include "core/base/error.h"

namespace ff {

namespace {

// An id the loader made (entry_ids: the stage's name, then name#2, name#3 ...), not one the user gave.
bool default_id(const StepEntry& e) {
  if (e.id == e.stage) return true;
  const std::string prefix = e.stage + "#";
  return e.id.size() > prefix.size() && e.id.compare(0, prefix.size(), prefix) == 0 &&
         e.id.find_first_not_of("0123456789", prefix.size()) == std::string::npos;
}

// The `walls` parameter of an entry that has one (overlap_correct, overlap_correct.verlet,
// voronoi.mirror, voronoi.mirror_observer; defaults filled), or nullptr.
const std::string* walls_of(const StepEntry& e) {
  auto it = e.params.all().find("walls");
  return it == e.params.all().end() ? nullptr : std::get_if<std::string>(&it->second);
}

bool corrects_overlaps(const StepEntry& e) { return e.stage.rfind("overlap_correct", 0) == 0; }

std::string line_of(const StepEntry& e) { return e.where.str() + set_by_note(e.set_by); }

std::string when(const Schedule& s) { return s.every_step() ? "every step" : s.text(); }

}  // namespace

int wall_axis(const PipelineSpec& spec) {
  for (const StepEntry& e : spec.step) {
    const std::string* w = walls_of(e);
    if (corrects_overlaps(e) && w && w->size() == 1 && (*w)[0] >= 'x' && (*w)[0] <= 'z') return (*w)[0] - 'x';
  }
  return -1;
}

// Every stage with a `walls` parameter must name the same walls: voronoi.mirror's cells are clipped
// at the planes the correction keeps the particles between; with other walls (or none) the particles
// cross the planes it clips at, and nothing else would say so. Refused, not warned: no pipeline means
// two different walls (a correction with `walls: none` lets pairs interact across the planes, and
// there is no other stage that confines the particles).
void StepGraph::check_walls(const PipelineSpec& spec) {
  const StepEntry* first = nullptr;
  for (const StepEntry& e : spec.step) {
    const std::string* w = walls_of(e);
    if (!w) continue;
    if (!first) {
      first = &e;
      continue;
    }
    const std::string& w0 = *walls_of(*first);
    if (*w == w0) continue;
    throw InputError(line_of(e) + ": step '" + e.id + "' has walls: " + *w + ", but step '" + first->id + "' (" +
                     line_of(*first) + ") has walls: " + w0 +
                     ": every stage with walls (overlap_correct, voronoi.mirror, voronoi.mirror_observer) must name "
                     "the same axis, or the cells are clipped at planes the particles cross (README \"Walls\")");
  }
}

std::vector<std::string> StepGraph::periodic_cells_in_slab(const PipelineSpec& spec) const {
  std::vector<std::string> out;
  const StepEntry* slab = nullptr;
  for (const StepEntry& e : spec.step)
    if (corrects_overlaps(e) && walls_of(e) && *walls_of(e) != "none") slab = &e;
  if (!slab) return out;
  for (const StepEntry& e : spec.step)
    if (e.stage == "voronoi.geometry")
      out.push_back(line_of(e) + ": step '" + e.id + "' (voronoi.geometry) makes the cells of the periodic box, but step '" +
                    slab->id + "' (" + line_of(*slab) + ") has walls: " + *walls_of(*slab) +
                    ": the cells of the disks at the walls reach across them. List {stage: voronoi.mirror, walls: " +
                    *walls_of(*slab) + "} (or voronoi.mirror_observer) instead: the cells clipped by the walls");
  return out;
}

std::vector<std::string> StepGraph::stale_observer_fields(const PipelineSpec& spec) const {
  std::vector<std::string> out;
  // Whether r runs at a step w does not (observers: steps 0 ... run.steps).
  auto misses = [&](const GraphNode& w, const GraphNode& r) {
    if (!w.schedule.log && !r.schedule.log) return r.schedule.every % w.schedule.every != 0;
    std::uint64_t checked = 0;
    if (r.schedule.log) {
      for (std::uint64_t s : r.steps)
        if (!w.runs_at(s)) return true;
      return false;
    }
    for (std::uint64_t s = 0; s <= spec.run.steps && checked < 1000000; s += r.schedule.every, ++checked)
      if (!w.runs_at(s)) return true;
    return false;
  };
  for (std::size_t r = 0; r < nodes_.size(); ++r) {
    if (!nodes_[r].observer) continue;
    for (std::size_t w = 0; w < r; ++w) {
      if (!nodes_[w].observer || !misses(nodes_[w], nodes_[r])) continue;
      std::string field;
      for (auto& a : nodes_[w].accesses)
        for (auto& b : nodes_[r].accesses)
          if (field.empty() && a.field == b.field && writes(a.mode) && reads(b.mode)) field = a.field;
      if (field.empty()) continue;
      const StepEntry& ew = spec.step[w];
      const StepEntry& er = spec.step[r];
      out.push_back(line_of(er) + ": step '" + er.id + "' (" + when(nodes_[r].schedule) + ") reads field '" + field +
                    "', which step '" + ew.id + "' (" + line_of(ew) + ") writes " + when(nodes_[w].schedule) +
                    ": at the steps '" + ew.id + "' skips, '" + er.id + "' writes its older values. Give both the same "
                    "schedule");
    }
  }
  return out;
}

StepGraph::StepGraph(const PipelineSpec& spec, std::vector<std::vector<Access>> accesses,
                     const std::vector<bool>& observer) {
  check_walls(spec);
  std::map<std::string, int> index;
  int previous_compute = -1;
  for (std::size_t i = 0; i < spec.step.size(); ++i) {
    const StepEntry& e = spec.step[i];
    GraphNode n;
    n.id = e.id;
    n.stage = e.stage;
    n.schedule = e.schedule;
    // Compute stages run on steps 0 ... steps - 1; observers see the state after 0 ... steps
    // steps (frame 0 is the initial configuration), so their last step is `steps`.
    if (e.schedule.log) n.steps = e.schedule.log_steps(observer[i] ? spec.run.steps + 1 : spec.run.steps);
    n.observer = observer[i];
    n.accesses = std::move(accesses[i]);
    n.where = e.where;
    if (!n.observer) {
      if (e.after_given) {
        for (auto& a : e.after) {
          auto it = index.find(a);
          if (it == index.end())
            throw InputError(e.where.str() + ": step '" + e.id + "': after: unknown id '" + a + "'");
          if (!nodes_[it->second].observer) n.preds.push_back(it->second);
        }
      } else if (previous_compute >= 0) {
        n.preds.push_back(previous_compute);
      }
      previous_compute = int(i);
    }
    index[e.id] = int(i);
    nodes_.push_back(std::move(n));
  }
  // Transitive closure; nodes only point backwards, so one pass in order suffices.
  const std::size_t n = nodes_.size();
  reach_.assign(n, std::vector<bool>(n, false));
  for (std::size_t b = 0; b < n; ++b)
    for (int p : nodes_[b].preds) {
      reach_[p][b] = true;
      for (std::size_t a = 0; a < n; ++a)
        if (reach_[a][p]) reach_[a][b] = true;
    }
  check_conflicts();
  check_overwrites();
}

// A stage that overwrites a field (Mode::write) another stage wrote earlier in the step, with
// nothing reading it in between, throws the first stage's work away: two force stages that each
// write `force` would not add up, only the last would count. Refused, naming both.
void StepGraph::check_overwrites() const {
  auto touches = [](const GraphNode& n, const std::string& f, bool reading) {
    for (auto& x : n.accesses)
      if (x.field == f && (reading ? reads(x.mode) : writes(x.mode))) return true;
    return false;
  };
  for (std::size_t b = 0; b < nodes_.size(); ++b) {
    if (nodes_[b].observer) continue;
    for (auto& y : nodes_[b].accesses) {
      if (y.mode != Mode::write || touches(nodes_[b], y.field, true)) continue;
      for (std::size_t a = 0; a < nodes_.size(); ++a) {
        if (nodes_[a].observer || !reach_[a][b] || !touches(nodes_[a], y.field, false)) continue;
        bool read_between = false;
        for (std::size_t c = 0; c < nodes_.size() && !read_between; ++c)
          read_between = !nodes_[c].observer && reach_[a][c] && reach_[c][b] && touches(nodes_[c], y.field, true);
        if (read_between) continue;
        throw InputError(nodes_[b].where.str() + ": step '" + nodes_[b].id + "' overwrites field '" + y.field +
                         "', which step '" + nodes_[a].id + "' wrote earlier in the step and no stage in between reads: '" +
                         nodes_[a].id + "' would do nothing (two stages writing '" + y.field +
                         "' do not add up; only the last one counts: a stage that adds to '" + y.field +
                         "' reads it too, declaring it readwrite, README \"Writing a stage or a model\")");
      }
    }
  }
}

// A stage listed twice with the same parameters and schedule, each moving the particles: most
// often a copied line, and for an integrator a step that moves twice (Δt, drift and noise
// doubled) with no error to show it. Said once per pair; an `id` on the second marks it as meant.
std::vector<std::string> StepGraph::repeated_movers(const PipelineSpec& spec) const {
  std::vector<std::string> out;
  auto moves = [&](std::size_t i) {
    for (auto& a : nodes_[i].accesses)
      if (a.field == "position" && writes(a.mode)) return true;
    return false;
  };
  for (std::size_t b = 0; b < nodes_.size(); ++b) {
    const StepEntry& eb = spec.step[b];
    if (nodes_[b].observer || !default_id(eb) || !moves(b)) continue;
    for (std::size_t a = 0; a < b; ++a) {
      const StepEntry& ea = spec.step[a];
      if (nodes_[a].observer || ea.stage != eb.stage || ea.params.all() != eb.params.all() ||
          ea.schedule.every != eb.schedule.every || ea.schedule.log != eb.schedule.log)
        continue;
      out.push_back(eb.where.str() + ": step '" + eb.id + "' repeats step '" + ea.id + "'" + (ea.where.line ? " (line " + std::to_string(ea.where.line) + ")" : std::string()) +
                    " with the same parameters, and both move the particles: each step then moves them twice (for an "
                    "integrator, as if Δt were doubled). Remove one, or give this one an "
                    "`id` if it is meant");
      break;
    }
  }
  return out;
}

std::vector<std::string> StepGraph::unread_writes(const PipelineSpec& spec) const {
  std::vector<std::string> out;
  for (const char* field : {"force", "velocity"}) {
    // Read by a compute stage: an observer that records it (observe.h5md's fields) moves nothing.
    bool read = false;
    for (auto& n : nodes_)
      if (!n.observer)
        for (auto& b : n.accesses) read = read || (b.field == field && b.mode != Mode::write);
    if (read) continue;
    for (std::size_t w = 0; w < nodes_.size(); ++w) {
      bool written = false;
      for (auto& a : nodes_[w].accesses) written = written || (a.field == field && writes(a.mode));
      if (nodes_[w].observer || !written) continue;
      // An integrator's `drift: auto` takes a drift field that exists when it is configured,
      // i.e. one a stage listed before it makes.
      bool mover_before = false;
      for (std::size_t i = 0; i < w; ++i)
        for (auto& b : nodes_[i].accesses) mover_before = mover_before || (b.field == fields::position && writes(b.mode));
      const StepEntry& e = spec.step[w];
      out.push_back(e.where.str() + ": step '" + e.id + "' writes field '" + field +
                    "', which no compute stage reads (observers only record it): it does not move the particles. " +
                    (mover_before ? std::string("The stage that moves them is listed before it, and `drift: auto` "
                                                "takes only a drift an earlier stage makes: list '") +
                                        e.id + "' first"
                                  : std::string("No integrator here takes it: ") +
                                        (std::string(field) == "force"
                                             ? "overdamped.integrate does (drift: auto or force)"
                                             : "overdamped.integrate (drift: auto or velocity) and phoretic.integrate do") +
                                        "; abp.integrate does not (`pipeline describe STAGE` lists what a stage reads)"));
      break;  // one warning a field
    }
  }
  return out;
}

void StepGraph::check_conflicts() const {
  for (std::size_t b = 0; b < nodes_.size(); ++b) {
    if (nodes_[b].observer) continue;
    for (std::size_t a = 0; a < b; ++a) {
      if (nodes_[a].observer || reach_[a][b] || reach_[b][a]) continue;
      for (auto& x : nodes_[a].accesses)
        for (auto& y : nodes_[b].accesses) {
          if (x.field != y.field || (!writes(x.mode) && !writes(y.mode))) continue;
          throw InputError(nodes_[b].where.str() + ": step '" + nodes_[b].id + "' and step '" + nodes_[a].id +
                           "' both use field '" + x.field + "' (" + (writes(y.mode) ? nodes_[b].id : nodes_[a].id) +
                           " writes it) but neither runs after the other; add `after: [" + nodes_[a].id +
                           "]` to '" + nodes_[b].id + "'");
        }
    }
  }
}

std::vector<int> StepGraph::compute_nodes() const {
  std::vector<int> v;
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (!nodes_[i].observer) v.push_back(int(i));
  return v;
}

std::vector<int> StepGraph::compute_order() const {
  const std::vector<int> compute = compute_nodes();
  std::vector<int> order;
  std::vector<bool> placed(nodes_.size(), false);
  while (order.size() < compute.size()) {
    const std::size_t before = order.size();
    for (int i : compute) {  // the lowest index whose predecessors are all placed
      if (placed[i]) continue;
      bool ready = true;
      for (int p : nodes_[i].preds) ready = ready && placed[p];
      if (!ready) continue;
      placed[i] = true;
      order.push_back(i);
      break;
    }
    if (order.size() == before) throw std::logic_error("StepGraph::compute_order: the compute phase has a cycle");
  }
  return order;
}

bool StepGraph::written_before_read(int w, const std::string& field) const {
  if (nodes_[w].schedule.log || nodes_[w].schedule.every != 1) return false;
  for (int k : compute_nodes()) {
    if (k == w || ordered(w, k)) continue;
    for (const Access& a : nodes_[k].accesses)
      if (a.field == field && a.mode != Mode::write) return false;
  }
  return true;
}

std::vector<int> StepGraph::observer_nodes() const {
  std::vector<int> v;
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    if (nodes_[i].observer) v.push_back(int(i));
  return v;
}

bool StepGraph::is_chain() const {
  const auto c = compute_nodes();
  for (std::size_t k = 1; k < c.size(); ++k)
    if (!reach_[c[k - 1]][c[k]]) return false;
  return true;
}

namespace {
std::string access_list(const GraphNode& n, bool want_write) {
  std::string s;
  for (auto& a : n.accesses)
    if (writes(a.mode) == want_write || (want_write == false && reads(a.mode)))
      s += (s.empty() ? "" : ", ") + a.field;
  return s.empty() ? "-" : s;
}
}  // namespace

std::string StepGraph::dot() const {
  std::ostringstream os;
  os << "digraph step {\n  rankdir=TB;\n  node [shape=box, fontname=\"Helvetica\"];\n";
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const auto& n = nodes_[i];
    os << "  n" << i << " [label=\"" << n.id;
    if (n.id != n.stage) os << "\\n(" << n.stage << ")";
    if (!n.schedule.every_step()) os << "\\n" << n.schedule.text();
    os << "\"" << (n.observer ? ", style=dashed" : "") << "];\n";
  }
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    for (int p : nodes_[i].preds) os << "  n" << p << " -> n" << i << ";\n";
  // Observers run after the whole compute phase: draw them hanging off the compute sinks.
  const auto obs = observer_nodes();
  const auto comp = compute_nodes();
  int last = -1;
  for (int c : comp) {
    bool sink = true;
    for (int d : comp) sink = sink && !reach_[c][d];
    if (sink && !obs.empty()) os << "  n" << c << " -> n" << obs.front() << " [style=dashed];\n";
  }
  for (int o : obs) {
    if (last >= 0) os << "  n" << last << " -> n" << o << " [style=dashed];\n";
    last = o;
  }
  os << "}\n";
  return os.str();
}

std::string StepGraph::summary() const {
  std::ostringstream os;
  os << "compute phase (runs each step, rolled back together):\n";
  for (int i : compute_nodes()) {
    const auto& n = nodes_[i];
    os << "  " << n.id << (n.id != n.stage ? " [" + n.stage + "]" : "") << (n.schedule.every_step() ? "" : " " + n.schedule.text())
       << "\n    after: ";
    if (n.preds.empty()) os << "(start)";
    for (std::size_t k = 0; k < n.preds.size(); ++k) os << (k ? ", " : "") << nodes_[n.preds[k]].id;
    os << "\n    reads: " << access_list(n, false) << "\n    writes: " << access_list(n, true) << "\n";
  }
  os << "observe phase (after each accepted step, in order):\n";
  for (int i : observer_nodes()) {
    const auto& n = nodes_[i];
    os << "  " << n.id << (n.schedule.every_step() ? "" : " " + n.schedule.text()) << "\n";
  }
  return os.str();
}

}  // namespace ff
