// observe.gr: the pair distribution function g(r), 2D and 3D, accumulated over every call from
// `from_step` on (use `every: k` to space the samples). Pairs within r_max are counted with a
// cell list (cells of edge ≥ r_max, so a pair is found in the 3^d cells around a particle),
// in parallel with integer histograms: the counts are the same for any thread count.
//
//   g(r_k) = H_k / (frames · N(N−1)/(2V) · shell_k),  shell_k = π(r_hi² − r_lo²) or 4π/3 (r_hi³ − r_lo³)
//
// r_max and fit_width are in units of σ, the mean diameter, for mixtures too (the total g(r) of all
// pairs); r in gr.csv (r_lo, r_hi, r) and the `sigma` of its first line are in box units.
//
// Metrics after each call, cumulative over the frames accumulated so far (not of the last frame
// alone); NaN before the first accumulated frame (before from_step):
//   g_contact  one diameter: g(σ⁺), a least-squares quadratic through the bins in
//              [σ, σ + fit_width·σ] (at least three), evaluated at r = σ.
//              Several diameters (a mixture): the weighted mean Σ_ij w_ij g_ij(σ_ij⁺) / Σ_ij w_ij,
//              w_ij = x_i x_j σ_ij^d over ordered species pairs, of the partial contact values
//   Z          the hard-core virial pressure βP/ρ. One diameter: 1 + 2η g(σ⁺) (2D), 1 + 4η g(σ⁺)
//              (3D), η the packing fraction. A mixture (additive hard disks/spheres):
//                2D: Z = 1 + (πρ/2) Σ_ij x_i x_j σ_ij² g_ij(σ_ij⁺)
//                3D: Z = 1 + (2πρ/3) Σ_ij x_i x_j σ_ij³ g_ij(σ_ij⁺)
//              ρ = N/V, x_i the number fraction of species i, σ_ij = (σ_i + σ_j)/2, i.e.
//              Z = 1 + (πρ/2)·Σw·g_contact (2D). For one diameter these are the formulas above
//              (πρσ²/2 = 2η, 2πρσ³/3 = 4η); equal diameters take that path unchanged, whatever
//              the number of types.
// A species is a `type`; its σ_i is the mean diameter of its particles (a warning when they
// differ). The partial g_ij near contact is histogrammed in r/σ_ij (σ_ij of the pair's own
// diameters), bins of the same reduced width as g(r)'s (r_max/bins), normalised by the ideal
// count of the pair class (N_i N_j pairs for i ≠ j, N_i(N_i − 1)/2 for i = j) and fitted like
// g(σ⁺); a class with no pair (one particle of its species) counts as g_ij = 0.
// finish() writes the histogram as CSV (`file`, default gr.csv) in the output directory:
// r_lo, r_hi, r, g, pairs, after '#' lines with N, σ, η, frames, g_contact and Z, and for a
// mixture one line per species pair, "# g_contact[A,B] = ...". Each checkpoint writes it as
// `file`.partial, which a completed run renames.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
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
    p(r_max, "r_max",
      "largest distance histogrammed, in units of σ (the mean diameter); gr.csv's r columns are in box units")
        .above(0);
    p(bins, "bins", "histogram bins over [0, r_max)").at_least(1).at_most(1000000);
    p(fit_width, "fit_width",
      "g(σ⁺) is a quadratic fit over the bins in [σ, σ + fit_width·σ] (at least three), in σ; for a mixture "
      "each g_ij(σ_ij⁺) over [σ_ij, σ_ij + fit_width·σ_ij]")
        .above(0);
    p(from_step, "from_step", "ignore calls before this step (equilibration)").at_least(0);
    p(file, "file", "CSV output, relative to the run's output directory");
  }
};

// The partial histograms near contact of a mixture: per particle its type (0 ≤ type < types) and
// diameter; `bins` bins of width ds in r/σ_ij from 0.
struct ContactWindow {
  const std::int32_t* type = nullptr;
  const double* diameter = nullptr;
  int types = 1;
  double ds = 0.02;
  std::size_t bins = 0;
};

// One frame's pair counts: hist[k] += unordered pairs with r in [k·dr, (k+1)·dr), r < r_max.
// `xyz` is N x dim (double), box edges L; cells[k] cells along axis k with L[k]/cells[k] ≥ r_max.
// With `contact`, also contact_hist[(a·types + b)·bins + k] += pairs of types a ≤ b with r/σ_ij
// in [k·ds, (k+1)·ds) (and r < r_max). Deterministic (integer sums) for any thread count.
void count_pairs(const std::vector<double>& xyz, int dim, const double* L, const int* cells, double r_max,
                 std::vector<std::uint64_t>& hist, const ContactWindow* contact = nullptr,
                 std::vector<std::uint64_t>* contact_hist = nullptr);

// g(σ⁺) from g per bin (edges k·dr): quadratic least squares over bins with r_lo ≥ σ and
// r_hi ≤ σ(1 + fit_width), at least three bins; 0 when there are not enough bins.
double contact_value(const std::vector<double>& g, double dr, double sigma, double fit_width);

class Gr final : public Stage {
 public:
  static StageDecl declaration() {
    return {"observe.gr",
            "pair distribution g(r) accumulated over calls (cell list); metrics g_contact = g(σ⁺) and the "
            "hard-core pressure Z (a mixture: the contact theorem over the species pairs' g_ij(σ_ij⁺)), "
            "cumulative, NaN before from_step; writes gr.csv",
            schema_of<GrParams>(), {2, 3}, true};
  }

  // Host accesses: on the CUDA backend the core brings the fields to the host.
  Gr(const ParamValues& v, const RunInfo& info) : Gr(params_from<GrParams>(v), info) {}
  Gr(GrParams p, RunInfo info) : p_(std::move(p)), info_(std::move(info)) {}

  std::vector<Access> accesses() const override {
    return {{fields::position, Where::host, Mode::read},
            {fields::diameter, Where::host, Mode::read},
            {fields::type, Where::host, Mode::read}};
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
  // Whether the particles have more than one diameter (the mixture contact theorem).
  bool mixture() const { return mixture_; }
  // A mixture's species names and its contact value g_ij(σ_ij⁺) of types i, j (NaN before the
  // first frame); with one diameter, g_contact.
  const std::vector<std::string>& species() const { return species_; }
  double pair_contact(int i, int j) const {
    return mixture_ ? pair_contact_[std::size_t(std::min(i, j) * types_ + std::max(i, j))] : g_contact_;
  }

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
  static constexpr double nan_ = std::numeric_limits<double>::quiet_NaN();
  double g_contact_ = nan_, z_ = nan_;
  // A mixture's species and their partial contact histograms (see ContactWindow).
  bool mixture_ = false;
  int types_ = 1;
  std::vector<std::string> species_;
  std::vector<double> species_sigma_, species_x_;
  std::vector<std::uint64_t> species_n_;
  std::vector<std::int32_t> type_;
  std::vector<double> diameter_;
  double ds_ = 0.02;
  std::size_t contact_bins_ = 0;
  std::vector<std::uint64_t> contact_hist_;
  std::uint64_t contact_frames_ = 0;  // frames in contact_hist_ (a checkpoint from before mixtures has none)
  std::vector<double> pair_contact_;
  void configure_mixture(State& s);
  void update_mixture_metrics();
  bool finished_ = false;
  std::string write_partial() const;  // the CSV as `file`.partial; returns its path
};

}  // namespace ff::observe

FLIPFLOW_HOST_STAGE(ff::observe::Gr)
