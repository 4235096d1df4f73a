// observe.clusters' analysis of one frame, apart from the stage that reads the state and writes
// the files (stage.h): candidate pairs from cells, a Verlet list or a triangulation's edges, then
// bonds, clusters, labels, coordination, percolation and type-pair counts (stage.h's header
// comment defines them). Host code; the pair rows are built in parallel (oneTBB), every result
// is integer work in a fixed order.
#pragma once
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace ff::observe {

// One frame on the host, in double.
struct ClusterFrame {
  int dim = 2;
  double L[3] = {0, 0, 0};
  std::vector<double> x;          // n x dim, wrapped into the box
  std::vector<double> diameter;   // n
  std::vector<std::int32_t> type; // n
  std::vector<std::uint8_t> takes_part;  // n: 1 when the particle's type is selected
  std::size_t n() const { return diameter.size(); }
};

// Candidate pairs of every particle as rows (CSR): row i is index[start[i] .. start[i+1]); each
// pair appears in both rows, at most once per row. What a source hands the bond test.
struct PairRows {
  std::vector<std::uint32_t> start;  // n + 1
  std::vector<std::uint32_t> index;
};

// What one call measures (also what the tests read).
struct ClusterResult {
  std::vector<std::int32_t> label;   // n: smallest index of the cluster; -1: takes no part
  std::vector<std::uint32_t> sizes;  // sizes of the clusters, in order of their labels
  std::uint64_t bonds = 0, unlike_bonds = 0;
  std::vector<std::uint64_t> bonds_by_pair;  // types t x t, [a * t + b] with a ≤ b
  std::uint64_t coordination_sum = 0;        // Σ over particles in aggregates of their neighbours
  std::uint64_t in_aggregates = 0;           // particles in aggregates
  std::uint64_t aggregates = 0, monomers = 0, largest = 0, taking_part = 0;
  std::array<int, 3> percolates{0, 0, 0};    // per axis
};

// Candidate rows from the cells of a grid of edge ≥ r (every pair closer than r is a candidate).
PairRows cell_pairs(const ClusterFrame& f, double r);
// Candidate rows from a Verlet list (N x capacity rows, count per row).
PairRows list_pairs(std::size_t n, const std::uint32_t* list, const std::uint32_t* count, std::uint32_t capacity);
// Candidate rows from the edges of a half-edge triangulation (he: 2 x 6n, {origin, next}).
PairRows edge_pairs(std::size_t n, const std::int32_t* he);

// Bonds (r < bond·σ_ij), clusters, labels, coordination (r < neighbor·σ_ij), percolation and
// type-pair counts from the candidate rows; `types` = number of species.
ClusterResult analyse_clusters(const ClusterFrame& f, const PairRows& rows, double bond, double neighbor,
                               std::int64_t min_size, int types);

// s² of the Gabriel bound for reach b (in σ_ij) over the diameters in `pair_diameters` (the
// species taking part: i, j) and `all_diameters` (any k): max b²σ_ij²/(σ_ik² + σ_jk²). The
// triangulation holds every pair within b·σ_ij when it is ≤ 1 and no two disks are closer than
// √(s²)·σ_kl.
double gabriel_ratio2(double b, const std::vector<double>& pair_diameters, const std::vector<double>& all_diameters);

// Minimum-image squared distance, and the integer box shift s (per axis) that takes j's wrapped
// position to its image nearest i: x_j + s·L − x_i is the minimum-image vector.
inline double distance2(const ClusterFrame& f, std::size_t i, std::size_t j, int* shift = nullptr) {
  double r2 = 0;
  for (int k = 0; k < f.dim; ++k) {
    const double d = f.x[j * f.dim + k] - f.x[i * f.dim + k];
    const double s = -std::rint(d / f.L[k]);
    if (shift) shift[k] = int(s);
    const double m = d + s * f.L[k];
    r2 += m * m;
  }
  return r2;
}

}  // namespace ff::observe
