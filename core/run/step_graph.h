// The step graph: which stage runs after which. Built once per run from the pipeline's order
// (each entry after the previous one unless it says `after:`) and checked against the fields
// each stage declares: two stages with no path between them must not touch the same field
// when either writes it, or the result would depend on thread timing.
//
// Observer stages (StageDecl::observer) form a second phase that runs, in file order, after
// the step is accepted (so a rolled-back attempt never reaches an output file).
#pragma once
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "core/input/pipeline_spec.h"
#include "core/stage/stage.h"

namespace ff {

// The axis (0 x, 1 y, 2 z) of the hard walls of the pipeline's overlap correction (`walls:`), or
// -1 without walls. StepGraph refuses stages whose walls differ, so there is one answer.
int wall_axis(const PipelineSpec& spec);

struct GraphNode {
  std::string id;
  std::string stage;
  Schedule schedule;                // `every` or `at` (core/input/pipeline_spec.h)
  std::vector<std::uint64_t> steps; // a log schedule's steps of this run, ascending
  bool runs_at(std::uint64_t step) const {
    if (schedule.log) return std::binary_search(steps.begin(), steps.end(), step);
    return step % schedule.every == 0;
  }
  bool observer = false;
  std::vector<int> preds;  // indices of nodes this one runs after (compute phase only)
  std::vector<Access> accesses;
  Location where;
};

class StepGraph {
 public:
  // accesses[i] and observer[i] describe spec.step[i]. Throws InputError on a conflict.
  StepGraph(const PipelineSpec& spec, std::vector<std::vector<Access>> accesses, const std::vector<bool>& observer);

  const std::vector<GraphNode>& nodes() const { return nodes_; }
  // True when a runs before b on every schedule (a path a -> ... -> b).
  bool ordered(int a, int b) const { return reach_[a][b]; }
  std::vector<int> compute_nodes() const;
  // The compute nodes in one order that keeps every `after` (a stage after all of its
  // predecessors), the lowest index first among those ready: the same on every rank of a team.
  std::vector<int> compute_order() const;
  std::vector<int> observer_nodes() const;
  // True when the compute phase is a single chain (no two stages can run concurrently).
  bool is_chain() const;
  // Whether node w's write of `field` is remade every step before anything else in the compute
  // phase reads it: w runs every step and every other compute stage that reads the field runs
  // after it. Only then can a retried step skip restoring it (Access::step_local).
  bool written_before_read(int w, const std::string& field) const;

  // Warnings, one a pair: a compute stage listed again with the same parameters and schedule,
  // both writing `position`, the later without an id of its own (a copied integrator line
  // moves every particle twice a step). spec is the one the graph was built from.
  std::vector<std::string> repeated_movers(const PipelineSpec& spec) const;
  // Warnings, one a field: a field a compute stage writes that no stage reads, other than the
  // particles' own (position, image, type, diameter, particle.id), which outputs and the next
  // step use. A force computed before an integrator that does not take it (abp.integrate), or
  // after the one that would (drift: auto sees no `force` yet), is such a field.
  std::vector<std::string> unread_writes(const PipelineSpec& spec) const;

  // Warnings, one an entry: voronoi.geometry (the torus's cells) in a pipeline whose overlap
  // correction has walls, where the cells cross the walls (voronoi.mirror clips them there).
  std::vector<std::string> periodic_cells_in_slab(const PipelineSpec& spec) const;
  // Warnings, one a pair: an observer that writes a field a later observer reads (voronoi.mirror_observer
  // and observe.h5md) at a step the writer does not run at: that frame holds the writer's last,
  // older, values.
  std::vector<std::string> stale_observer_fields(const PipelineSpec& spec) const;

  std::string dot() const;      // Graphviz
  std::string summary() const;  // the resolved graph in words, for `pipeline validate`

 private:
  void check_conflicts() const;
  void check_overwrites() const;
  static void check_walls(const PipelineSpec& spec);
  std::vector<GraphNode> nodes_;
  std::vector<std::vector<bool>> reach_;
};

}  // namespace ff
