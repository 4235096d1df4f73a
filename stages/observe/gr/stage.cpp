#include "stages/observe/gr/stage.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "core/base/error.h"
#include "core/io/durable_file.h"
#include "stages/observe/cell_grid.h"

namespace ff::observe {

namespace {
constexpr double pi = 3.14159265358979323846;

template <class R>
void to_double(const Field& f, std::vector<double>& out) {
  const R* p = f.host<R>();
  out.assign(p, p + f.size());
}
}  // namespace

void count_pairs(const std::vector<double>& xyz, int dim, const double* L, const int* cells, double r_max,
                 std::vector<std::uint64_t>& hist) {
  const std::size_t n = xyz.size() / std::size_t(dim);
  const std::size_t bins = hist.size();
  const double dr = r_max / double(bins), inv_dr = 1.0 / dr, r2max = r_max * r_max;
  const CellGrid grid(xyz.data(), n, dim, L, cells);
  using Hist = std::vector<std::uint64_t>;
  const Hist frame = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 512), Hist(bins, 0),
      [&](const tbb::blocked_range<std::size_t>& r, Hist h) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          grid.for_each_candidate(i, [&](std::size_t j) {
            if (j <= i) return;
            double r2 = 0;
            for (int k = 0; k < dim; ++k) {
              double d = xyz[j * dim + k] - xyz[i * dim + k];
              d -= L[k] * std::rint(d / L[k]);
              r2 += d * d;
            }
            if (r2 >= r2max) return;
            const std::size_t bin = std::size_t(std::sqrt(r2) * inv_dr);
            if (bin < bins) ++h[bin];
          });
        }
        return h;
      },
      [](Hist a, const Hist& b) {
        for (std::size_t k = 0; k < a.size(); ++k) a[k] += b[k];
        return a;
      });
  for (std::size_t k = 0; k < bins; ++k) hist[k] += frame[k];
}

double contact_value(const std::vector<double>& g, double dr, double sigma, double fit_width) {
  const double eps = 1e-9 * dr;
  std::size_t first = std::size_t(std::ceil(sigma / dr - 1e-9));  // first bin with r_lo ≥ σ
  std::size_t last = first;                                        // one past the last bin fitted
  while (last < g.size() && (double(last) + 1) * dr <= sigma * (1 + fit_width) + eps) ++last;
  last = std::max(last, first + 3);
  if (last > g.size()) return 0;
  // Normal equations of g ≈ c0 + c1 x + c2 x², x = r_mid − σ (in units of dr).
  double S[5] = {0, 0, 0, 0, 0}, T[3] = {0, 0, 0};
  for (std::size_t k = first; k < last; ++k) {
    const double x = (double(k) + 0.5) - sigma / dr;
    double p = 1;
    for (int m = 0; m < 5; ++m) {
      S[m] += p;
      if (m < 3) T[m] += p * g[k];
      p *= x;
    }
  }
  double A[3][4] = {{S[0], S[1], S[2], T[0]}, {S[1], S[2], S[3], T[1]}, {S[2], S[3], S[4], T[2]}};
  for (int c = 0; c < 3; ++c) {  // Gaussian elimination with partial pivoting
    int piv = c;
    for (int r = c + 1; r < 3; ++r)
      if (std::fabs(A[r][c]) > std::fabs(A[piv][c])) piv = r;
    std::swap(A[c], A[piv]);
    if (A[c][c] == 0) return 0;
    for (int r = 0; r < 3; ++r) {
      if (r == c) continue;
      const double f = A[r][c] / A[c][c];
      for (int k = c; k < 4; ++k) A[r][k] -= f * A[c][k];
    }
  }
  return A[0][3] / A[0][0];
}

void Gr::configure(State& s) {
  dim_ = s.dim();
  n_ = s.n();
  double lmin = HUGE_VAL;
  for (int k = 0; k < dim_; ++k) {
    L_[k] = s.box.L[k];
    lmin = std::min(lmin, L_[k]);
  }
  volume_ = s.box.volume();
  Field& d = s.field(fields::diameter);
  d.acquire(Where::host, Mode::read);
  std::vector<double> diam;
  if (d.dtype() == DType::f32)
    to_double<float>(d, diam);
  else
    to_double<double>(d, diam);
  double sum = 0, occupied = 0;
  for (double x : diam) {
    sum += x;
    occupied += dim_ == 2 ? pi * x * x / 4 : pi * x * x * x / 6;
  }
  sigma_ = n_ ? sum / double(n_) : 1.0;
  eta_ = occupied / volume_;
  r_max_ = p_.r_max * sigma_;
  if (n_ < 2) throw InputError("observe.gr: g(r) needs at least two particles");
  // Not an error: a short trial run (--set run.steps=100) of a long run's pipeline is common.
  if (info_.steps > 0 && std::uint64_t(p_.from_step) > info_.steps)
    std::fprintf(info_.messages,
                 "flipflow: warning: observe.gr: from_step = %lld is after the run's last step (%llu): g(r) stays "
                 "empty in this run (lower from_step, or lengthen run.steps)\n",
                 static_cast<long long>(p_.from_step), static_cast<unsigned long long>(info_.steps));
  if (2 * r_max_ > lmin)
    throw InputError("observe.gr: r_max = " + std::to_string(p_.r_max) + "σ = " + std::to_string(r_max_) +
                     " is more than half the smallest box edge (" + std::to_string(lmin) +
                     "); pairs would be seen twice through the periodic box: lower r_max or use a larger system");
  dr_ = r_max_ / double(p_.bins);
  for (int k = 0; k < 3; ++k) cells_[k] = k < dim_ ? std::max(1, int(std::floor(L_[k] / r_max_))) : 1;
  hist_.assign(std::size_t(p_.bins), 0);
}

std::vector<double> Gr::g() const {
  std::vector<double> g(hist_.size(), 0.0);
  if (!frames_) return g;
  const double pairs_density = double(n_) * double(n_ - 1) / (2 * volume_);  // unordered pairs per volume
  for (std::size_t k = 0; k < g.size(); ++k) {
    const double lo = double(k) * dr_, hi = double(k + 1) * dr_;
    const double shell = dim_ == 2 ? pi * (hi * hi - lo * lo) : 4.0 / 3.0 * pi * (hi * hi * hi - lo * lo * lo);
    g[k] = double(hist_[k]) / (double(frames_) * pairs_density * shell);
  }
  return g;
}

Outcome Gr::run(StepContext& ctx) {
  if (ctx.host_params.step >= std::uint64_t(p_.from_step)) {
    const Field& x = ctx.state.field(fields::position);
    if (x.dtype() == DType::f32)
      to_double<float>(x, xyz_);
    else
      to_double<double>(x, xyz_);
    count_pairs(xyz_, dim_, L_, cells_, r_max_, hist_);
    ++frames_;
    g_contact_ = contact_value(g(), dr_, sigma_, p_.fit_width);
    z_ = 1 + (dim_ == 2 ? 2 : 4) * eta_ * g_contact_;
  }
  ctx.metrics.set("g_contact", g_contact_);
  ctx.metrics.set("Z", z_);
  return Outcome::ok();
}

void Gr::save_state(StageState& out) {
  out.put("hist", hist_);
  out.put("frames", frames_);
  out.put("g_contact", g_contact_);
  out.put("z", z_);
  if (!info_.out_dir.empty()) write_partial();
}

void Gr::restore_state(const StageState& saved, State&) {
  if (!saved.has("hist")) return;
  auto hist = saved.get_vector<std::uint64_t>("hist");
  if (hist.size() != hist_.size())
    throw InputError("observe.gr: the checkpoint's histogram has " + std::to_string(hist.size()) +
                     " bins, this pipeline's " + std::to_string(hist_.size()) + " (bins or r_max changed)");
  hist_ = std::move(hist);
  frames_ = saved.get<std::uint64_t>("frames");
  g_contact_ = saved.get<double>("g_contact");
  z_ = saved.get<double>("z");
}

// At each checkpoint too (save_state): a run killed outright (kill -9, the node lost) then
// leaves the g(r) of its newest checkpoint beside it, not only bytes inside the checkpoint.
std::string Gr::write_partial() const {
  const std::string partial = (std::filesystem::path(info_.out_dir) / p_.file).string() + ".partial";
  std::ostringstream out;
  out.precision(17);
  out << "# observe.gr: pair distribution g(r), " << dim_ << "D, N = " << n_ << ", sigma = " << sigma_
      << ", packing_fraction = " << eta_ << ", frames = " << frames_ << "\n";
  out << "# g_contact = " << g_contact_ << ", Z = " << z_ << " (1 + " << (dim_ == 2 ? 2 : 4)
      << " eta g_contact)\n";
  out << "r_lo,r_hi,r,g,pairs\n";
  const auto gk = g();
  for (std::size_t k = 0; k < hist_.size(); ++k) {
    const double lo = double(k) * dr_, hi = double(k + 1) * dr_;
    out << lo << "," << hi << "," << 0.5 * (lo + hi) << "," << gk[k] << "," << hist_[k] << "\n";
  }
  // Replaced whole: a kill during a checkpoint leaves the previous checkpoint's file.
  io::write_text_durably(partial, out.str(), "observe.gr");
  return partial;
}

void Gr::finish(State&, bool completed) {
  if (finished_ || info_.out_dir.empty()) return;
  finished_ = true;
  const std::string partial = write_partial();
  if (!completed) {
    std::fprintf(info_.messages, "flipflow: the run did not complete; g(r) so far is kept at '%s'\n", partial.c_str());
    return;
  }
  const std::filesystem::path path = std::filesystem::path(info_.out_dir) / p_.file;
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (ec) throw RunError("observe.gr: cannot rename '" + partial + "' to '" + path.string() + "': " + ec.message());
}

}  // namespace ff::observe
