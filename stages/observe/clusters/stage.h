// observe.clusters: bonds, clusters, aggregates, coordination and percolation (seed-gaps G1;
// Tran 2015 §2.1 and Fig. 3: "an aggregate is an assembly of at least two colloids"), 2D and 3D.
//
//   bond       i and j (both taking part, see `types`) with r_ij < bond·σ_ij, σ_ij = (σ_i + σ_j)/2,
//              minimum image; strict <
//   cluster    a connected component of the bond graph (a monomer is a cluster of one)
//   aggregate  a cluster of at least `min_size` particles
//   label      the smallest particle index of the cluster: canonical, whatever the pair source,
//              the particle order of the pairs or the thread count
//
// Metrics after each call (observe.h5md writes them under /observables/<stage id>/<metric>):
//   clusters, aggregates, monomers, largest (particles in the largest cluster), largest_fraction
//   (largest / particles taking part), mean_aggregate_size (particles in aggregates / aggregates;
//   0 without aggregates), coordination (mean number of particles within neighbor_radius·σ_ij,
//   over the particles in aggregates), bonds, bonds_<a>_<b> per type pair a ≤ b (species names),
//   unlike_fraction (bonds between unlike types / bonds; 0 without bonds), percolating (axes
//   along which some cluster wraps the periodic box, 0..dim) and percolating_x/_y/_z (1 when
//   some cluster wraps along that axis). A cluster wraps along axis k when a closed path of its
//   bonds, each taken as its minimum-image vector, sums to a non-zero multiple of L_k: each
//   member gets an integer image offset by a walk from the label over the bonds, and a bond
//   that reaches a member with a different offset than it has along k wraps.
//
// Pairs (`pairs`), all giving the same bonds when they may be used:
//   cells     its own cell list (cells of edge ≥ max(bond, neighbor_radius)·σ_max); needs nothing
//   verlet    the rows of neighbors.list (stages/neighbors/list.h), distances tested here. At
//             configure neighbors.cutoff must be ≥ max(bond, neighbor_radius)·σ_max. The list is
//             complete for the pairs within `cutoff` of each other when it was built; positions have
//             moved since (at most skin/2 plus the step's move), so a call uses it only when
//             max(bond, neighbor_radius)·σ_max + 2·(largest move since the build) ≤ cutoff, else
//             its own cell list (column `fallback` = 1). Give the list a margin (T2: cutoff 1.5σ
//             for bond 1.1).
//   delaunay  (2D) the edges of the maintained triangulation (stages/delaunay/common/fields.h).
//             A pair within b·σ_ij whose diametral disk holds another disk's centre k means
//             |ki|² + |kj|² < b²σ_ij²; with b²σ_ij² ≤ σ_ik² + σ_jk² for every type triple, k
//             would overlap i or j. So for non-overlapping disks every pair within
//             b = max(bond, neighbor_radius) is a Gabriel edge, hence a Delaunay edge. Configure
//             refuses b and diameters that break this bound (monodisperse: b ≤ √2). A call uses
//             the triangulation only when it is built, every triangle is positive, every edge is
//             locally Delaunay for the current positions (in-circle ≤ 1e-10 × its permanent:
//             overlap_correct may move disks after delaunay.lawson) and no Delaunay edge is
//             shorter than s·σ_ij, s² = max over the triples of b²σ_ij²/(σ_ik² + σ_jk²) (the
//             overlap the bound tolerates; for equal diameters this covers every pair, since a
//             disk's nearest neighbour is a Delaunay edge); otherwise its own cell list
//             (`fallback` = 1).
//
// Files written at finish() in the output directory (and as NAME.partial at each checkpoint,
// which a completed run renames):
//   clusters.csv (`file`): one row per call: step, time, clusters, aggregates, monomers, largest,
//     largest_fraction, mean_aggregate_size, coordination, bonds, unlike_fraction, percolating,
//     percolating_x, percolating_y[, percolating_z], bonds_<a>_<b>... (type pairs in order),
//     fallback; after '#' lines with N, the parameters and the pair source.
//   cluster_sizes.csv (`sizes_file`), `sizes_layout: wide` (the default): one row per call: step,
//     time, n1 ... n(K-1), nKplus with K = `size_columns` (default 64: n1 ... n63, n64plus): the
//     number of clusters of each size; the last column counts those of K particles or more. A MIPS
//     study that needs the tail of large clusters raises K (K = N gives every size its own
//     column), or takes `sizes_layout: long`: one row per call and cluster size present (step,
//     time, size, clusters), every size exact, K unused; a file of about (distinct sizes) rows a
//     call instead of K columns. The stage keeps each call's sizes exactly (the sizes present and
//     their counts, at most ~√(2N) of them), so a continued run may change K or the layout either
//     way. A checkpoint of flipflow before session 40 kept the wide columns: its rows continue
//     with the same or a smaller K, or with any K or layout where no cluster reached its last
//     column.
// With `label_field: true` the stage writes the per-particle field `cluster.label` (i32, the
// cluster's label; -1 for particles that take no part), which observe.h5md can write (list
// observe.clusters before observe.h5md, with the same schedule).
//
// Host-only: positions, diameters and types are read on the host (the core copies them from the
// device on CUDA runs). Pair search and bond tests run in parallel (oneTBB) into per-particle
// rows; the union-find, the labels and every metric are integer work in a fixed order, so the
// results are the same for any thread count.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"
#include "stages/observe/clusters/analysis.h"

namespace ff::observe {

struct ClustersParams {
  double bond = 1.1;            // bond length in units of σ_ij
  std::int64_t min_size = 2;    // smallest aggregate
  double neighbor_radius = 0;   // coordination radius in units of σ_ij; 0 = bond
  std::string pairs = "cells";
  std::vector<std::string> types;  // empty: every type
  bool label_field = false;
  std::string file = "clusters.csv";
  std::string sizes_file = "cluster_sizes.csv";
  std::int64_t size_columns = 64;
  std::string sizes_layout = "wide";

  template <class P>
  void describe(P& p) {
    p(bond, "bond", "i and j are bonded when r_ij < bond·σ_ij (σ_ij = (σ_i + σ_j)/2, minimum image)").above(0);
    p(min_size, "min_size", "an aggregate is a cluster of at least this many particles").at_least(1);
    p(neighbor_radius, "neighbor_radius",
      "metric `coordination` counts the particles within neighbor_radius·σ_ij (0: the bond length)")
        .at_least(0);
    p(pairs, "pairs",
      "where candidate pairs come from: cells (own cell list), verlet (neighbors.list; cutoff ≥ bond·σ_max), "
      "delaunay (2D triangulation; only where the Gabriel bound bond²σ_ij² ≤ σ_ik² + σ_jk² holds)")
        .one_of({"cells", "verlet", "delaunay"});
    p(types, "types", "only particles of these species take part (names from system.types); empty: all");
    p(label_field, "label_field",
      "write the per-particle field cluster.label (i32: the smallest index of the particle's cluster, -1 if it "
      "takes no part)");
    p(file, "file", "CSV of the metrics, one row per call, relative to the run's output directory");
    p(sizes_file, "sizes_file",
      "CSV of the cluster-size histogram, in the layout sizes_layout gives (tools/render draws it as the size "
      "distribution)");
    // The upper bound keeps a wide file's rows sane: each is 2 + K numbers.
    p(size_columns, "size_columns",
      "K, the size columns of sizes_file in the wide layout: n1 ... n(K-1) count the clusters of each size, "
      "nKplus those of K particles or more (K = N: every size its own column)")
        .at_least(2)
        .at_most(1000000);
    p(sizes_layout, "sizes_layout",
      "sizes_file's layout: wide (a row per call: step, time, n1 ... nKplus) or long (a row per call and size "
      "present: step, time, size, clusters; every size exact, size_columns unused)")
        .one_of({"wide", "long"});
  }
};

inline constexpr const char* cluster_label_field = "cluster.label";

class Clusters final : public Stage {
 public:
  static StageDecl declaration() {
    return {"observe.clusters",
            "bonds (r < bond·σ_ij), clusters, aggregates, coordination, like/unlike bonds and percolation; metrics "
            "per call, clusters.csv and cluster_sizes.csv (n1 ... nKplus, K = size_columns; or a row per size "
            "present); optional field cluster.label",
            schema_of<ClustersParams>(), {2, 3}, true};
  }

  // Host accesses: on the CUDA backend the core brings the fields to the host.
  Clusters(const ParamValues& v, const RunInfo& info) : Clusters(params_from<ClustersParams>(v), info) {}
  Clusters(ClustersParams p, RunInfo info);

  std::vector<Access> accesses() const override;
  void configure(State& s) override;
  Outcome run(StepContext& ctx) override;
  void finish(State& s, bool completed) override;
  std::vector<std::string> outputs() const override { return {p_.file, p_.sizes_file}; }
  // The rows of both CSV files so far (written at the end of the run) and the fallback count.
  void save_state(StageState& out) override;
  void restore_state(const StageState& saved, State& s) override;

  const ClusterResult& last() const { return last_; }

 private:
  enum class Source { cells, verlet, delaunay };
  void read_frame(const State& s);
  bool verlet_usable(const State& s) const;
  std::string delaunay_unusable(const State& s) const;  // why not, or empty
  // One CSV as NAME.partial, its '#' line then `table` (header and rows; returns its path); both
  // files' partials (returns their paths).
  std::string write_partial(const std::string& name, const std::string& table) const;
  std::vector<std::string> write_partials() const;

  ClustersParams p_;
  RunInfo info_;
  Source source_ = Source::cells;
  double reach_ = 1.1;       // max(bond, neighbor_radius), in σ_ij
  double neighbor_ = 1.1;    // neighbor_radius resolved
  double sigma_max_ = 1;     // largest diameter taking part
  double search_ = 1.1;      // reach_·σ_max_: every pair of interest is closer than this
  double gabriel_s2_ = 0;    // delaunay: the tolerated contact ratio, squared
  double verlet_cutoff_ = 0;
  int types_ = 1;
  std::vector<std::string> species_;
  ClusterFrame frame_;
  ClusterResult last_;
  std::vector<std::string> columns_;
  // One call's cluster sizes: (size, clusters of that size) for each size present, by size. A
  // row restored from a checkpoint of wide columns (before session 40) counts its sizes from
  // tail_from on together in `tail` (tail_from 0: none).
  struct SizeRow {
    double step = 0, time = 0;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> counts;
    std::uint64_t tail_from = 0, tail = 0;
  };
  std::string sizes_text() const;  // sizes_file's header line and rows
  std::vector<std::vector<double>> rows_;
  std::vector<SizeRow> size_rows_;
  std::uint64_t fallbacks_ = 0;
  bool warned_ = false, finished_ = false;
};

}  // namespace ff::observe

FLIPFLOW_HOST_STAGE(ff::observe::Clusters)
