// observe.gr: the pair distribution function g(r), 2D and 3D, accumulated over every call from
// `from_step` on (use `every: k` to space the samples). Pairs within r_max are counted with a
// cell list (cells of edge ≥ r_max, so a pair is found in the 3^d cells around a particle),
// in parallel with integer histograms: the counts are the same for any thread count.
//
//   g(r_k) = H_k / (frames · N(N−1)/(2V) · shell_k),  shell_k = π(r_hi² − r_lo²) or 4π/3 (r_hi³ − r_lo³)
//
// Metrics after each call (from the accumulated histogram):
//   g_contact  g(σ⁺): a least-squares quadratic through the bins in [σ, σ + fit_width·σ]
//              (at least three), evaluated at r = σ; σ is the mean diameter (the contact value
//              is meant for equal disks/spheres)
//   Z          the hard-core virial pressure βP/ρ = 1 + 2η g(σ⁺) (2D), 1 + 4η g(σ⁺) (3D), η the
//              packing fraction
// finish() writes the histogram as CSV (`file`, default gr.csv) in the output directory:
// r_lo, r_hi, r, g, pairs, after '#' lines with N, σ, η, frames, g_contact and Z. Each
// checkpoint writes it as `file`.partial, which a completed run renames.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/stage/params.h"
#include "core/stage/stage.h"
#include "core/stage/stage_registration.h"

namespace ff::observe {

struct GrParams {
  double r_max = 3.0;        // in units of σ
  std::int64_t bins = 150;
  double fit_width = 0.1;    // in units of σ
  std::int64_t from_step = 0;
  std::string file = "gr.csv";

  template <class P>
  void describe(P& p) {
    p(r_max, "r_max", "largest distance histogrammed, in units of σ (the mean diameter)").above(0);
    p(bins, "bins", "histogram bins over [0, r_max)").at_least(1).at_most(1000000);
    p(fit_width, "fit_width",
      "g(σ⁺) is a quadratic fit over the bins in [σ, σ + fit_width·σ] (at least three), in σ")
        .above(0);
    p(from_step, "from_step", "ignore calls before this step (equilibration)").at_least(0);
    p(file, "file", "CSV output, relative to the run's output directory");
  }
};

// One frame's pair counts: hist[k] += unordered pairs with r in [k·dr, (k+1)·dr), r < r_max.
// `xyz` is N x dim (double), box edges L; cells[k] cells along axis k with L[k]/cells[k] ≥ r_max.
// Deterministic (integer sums) for any thread count.
void count_pairs(const std::vector<double>& xyz, int dim, const double* L, const int* cells, double r_max,
                 std::vector<std::uint64_t>& hist);

// g(σ⁺) from g per bin (edges k·dr): quadratic least squares over bins with r_lo ≥ σ and
// r_hi ≤ σ(1 + fit_width), at least three bins; 0 when there are not enough bins.
double contact_value(const std::vector<double>& g, double dr, double sigma, double fit_width);

class Gr final : public Stage {
 public:
  static StageDecl declaration() {
    return {"observe.gr",
            "pair distribution g(r) accumulated over calls (cell list); metrics g_contact = g(σ⁺) and the "
            "hard-core pressure Z; writes gr.csv",
            schema_of<GrParams>(), {2, 3}, true};
  }

  // Host accesses: on the CUDA backend the core brings the fields to the host.
  Gr(const ParamValues& v, const RunInfo& info) : Gr(params_from<GrParams>(v), info) {}
  Gr(GrParams p, RunInfo info) : p_(std::move(p)), info_(std::move(info)) {}

  std::vector<Access> accesses() const override {
    return {{fields::position, Where::host, Mode::read}, {fields::diameter, Where::host, Mode::read}};
  }
  void configure(State& s) override;
  Outcome run(StepContext& ctx) override;
  void finish(State& s, bool completed) override;
  std::vector<std::string> outputs() const override { return {p_.file}; }
  // The histogram and frame count: a continued run keeps accumulating, and writes the CSV of
  // the whole run at its end.
  void save_state(StageState& out) override;
  void restore_state(const StageState& saved, State& s) override;

  // The accumulated g(r) per bin (0 before the first frame).
  std::vector<double> g() const;
  double dr() const { return dr_; }
  double sigma() const { return sigma_; }

 private:
  GrParams p_;
  RunInfo info_;
  int dim_ = 2;
  std::size_t n_ = 0;
  double L_[3] = {0, 0, 0};
  double volume_ = 0;
  double sigma_ = 1;  // mean diameter
  double eta_ = 0;    // packing fraction
  double r_max_ = 3;  // absolute
  double dr_ = 0.02;
  int cells_[3] = {1, 1, 1};
  std::vector<std::uint64_t> hist_;
  std::uint64_t frames_ = 0;
  std::vector<double> xyz_;  // scratch: positions in double
  double g_contact_ = 0, z_ = 1;
  bool finished_ = false;
  std::string write_partial() const;  // the CSV as `file`.partial; returns its path
};

}  // namespace ff::observe

FLIPFLOW_HOST_STAGE(ff::observe::Gr)
