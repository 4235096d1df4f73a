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
                 std::vector<std::uint64_t>& hist, const ContactWindow* contact, std::vector<std::uint64_t>* contact_hist) {
  const std::size_t n = xyz.size() / std::size_t(dim);
  const std::size_t bins = hist.size();
  const double dr = r_max / double(bins), inv_dr = 1.0 / dr, r2max = r_max * r_max;
  const std::size_t cbins = contact ? contact->bins : 0;
  const int types = contact ? contact->types : 0;
  const double inv_ds = contact ? 1.0 / contact->ds : 0.0;
  const std::size_t total = bins + cbins * std::size_t(types) * std::size_t(types);
  const CellGrid grid(xyz.data(), n, dim, L, cells);
  using Hist = std::vector<std::uint64_t>;
  // One reduction for both histograms: the contact bins follow the g(r) bins.
  const Hist frame = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 512), Hist(total, 0),
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
            const double dist = std::sqrt(r2);
            const std::size_t bin = std::size_t(dist * inv_dr);
            if (bin < bins) ++h[bin];
            if (contact) {
              const std::int32_t a = std::min(contact->type[i], contact->type[j]);
              const std::int32_t b = std::max(contact->type[i], contact->type[j]);
              const double sigma_ij = 0.5 * (contact->diameter[i] + contact->diameter[j]);
              const std::size_t cbin = std::size_t(dist / sigma_ij * inv_ds);
              if (cbin < cbins) ++h[bins + (std::size_t(a) * std::size_t(types) + std::size_t(b)) * cbins + cbin];
            }
          });
        }
        return h;
      },
      [](Hist a, const Hist& b) {
        for (std::size_t k = 0; k < a.size(); ++k) a[k] += b[k];
        return a;
      });
  for (std::size_t k = 0; k < bins; ++k) hist[k] += frame[k];
  if (contact && contact_hist)
    for (std::size_t k = bins; k < total; ++k) (*contact_hist)[k - bins] += frame[k];
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
  diameter_ = std::move(diam);
  mixture_ = std::any_of(diameter_.begin(), diameter_.end(), [&](double x) { return x != diameter_[0]; });
  if (mixture_) configure_mixture(s);
  else diameter_.clear();
}

void Gr::configure_mixture(State& s) {
  Field& t = s.field(fields::type);
  t.acquire(Where::host, Mode::read);
  type_.assign(t.host<std::int32_t>(), t.host<std::int32_t>() + n_);
  types_ = std::max<int>(1, int(s.species.size()));
  for (std::size_t i = 0; i < n_; ++i) {
    if (type_[i] < 0)
      throw InputError("observe.gr: particle " + std::to_string(i) + " has type " + std::to_string(type_[i]));
    types_ = std::max(types_, type_[i] + 1);
  }
  species_ = s.species;
  for (int a = int(species_.size()); a < types_; ++a) species_.push_back(std::to_string(a));
  species_.resize(std::size_t(types_));
  species_n_.assign(std::size_t(types_), 0);
  std::vector<double> sum(std::size_t(types_), 0), lo(std::size_t(types_), HUGE_VAL), hi(std::size_t(types_), -HUGE_VAL);
  for (std::size_t i = 0; i < n_; ++i) {
    const std::size_t a = std::size_t(type_[i]);
    ++species_n_[a];
    sum[a] += diameter_[i];
    lo[a] = std::min(lo[a], diameter_[i]);
    hi[a] = std::max(hi[a], diameter_[i]);
  }
  species_sigma_.assign(std::size_t(types_), 0);
  species_x_.assign(std::size_t(types_), 0);
  double sigma_max = 0;
  for (int a = 0; a < types_; ++a) {
    if (!species_n_[a]) continue;
    species_sigma_[a] = lo[a] == hi[a] ? lo[a] : sum[a] / double(species_n_[a]);  // exact for one diameter
    species_x_[a] = double(species_n_[a]) / double(n_);
    sigma_max = std::max(sigma_max, hi[a]);
    if (lo[a] != hi[a])
      std::fprintf(info_.messages,
                   "flipflow: warning: observe.gr: the particles of type %s have diameters from %g to %g; the "
                   "mixture contact theorem takes one diameter per species, so Z uses their mean %g\n",
                   species_[a].c_str(), lo[a], hi[a], species_sigma_[a]);
  }
  ds_ = p_.r_max / double(p_.bins);
  contact_bins_ = std::size_t(std::ceil((1 + p_.fit_width) / ds_)) + 4;
  // Every pair of the window must be within r_max, where the cell list finds pairs.
  const double reach = sigma_max * double(contact_bins_) * ds_;
  if (reach > r_max_)
    throw InputError("observe.gr: the contact window of the largest diameter (" + std::to_string(sigma_max) +
                     ") reaches r = " + std::to_string(reach) + ", beyond r_max·σ = " + std::to_string(r_max_) +
                     ": raise r_max (in units of the mean diameter) or lower fit_width");
  contact_hist_.assign(std::size_t(types_) * std::size_t(types_) * contact_bins_, 0);
  pair_contact_.assign(std::size_t(types_) * std::size_t(types_), nan_);
}

// The partial contact values, and the contact theorem summed over ordered species pairs.
void Gr::update_mixture_metrics() {
  const double rho = double(n_) / volume_;
  const double prefactor = dim_ == 2 ? pi / 2 : 2 * pi / 3;
  double weights = 0, weighted = 0;
  std::vector<double> g(contact_bins_);
  for (int a = 0; a < types_; ++a)
    for (int b = a; b < types_; ++b) {
      const std::size_t cls = std::size_t(a * types_ + b);
      const double na = double(species_n_[a]), nb = double(species_n_[b]);
      const double pairs = a == b ? na * (na - 1) / 2 : na * nb;
      const double sigma_ab = 0.5 * (species_sigma_[a] + species_sigma_[b]);
      double gc = 0;
      if (pairs > 0 && contact_frames_) {
        const double scale = std::pow(sigma_ab, dim_);
        for (std::size_t k = 0; k < contact_bins_; ++k) {
          const double lo = double(k) * ds_, hi = double(k + 1) * ds_;
          const double shell =
              dim_ == 2 ? pi * (hi * hi - lo * lo) : 4.0 / 3.0 * pi * (hi * hi * hi - lo * lo * lo);
          g[k] = double(contact_hist_[cls * contact_bins_ + k]) /
                 (double(contact_frames_) * pairs / volume_ * shell * scale);
        }
        gc = contact_value(g, ds_, 1.0, p_.fit_width);
      }
      pair_contact_[cls] = contact_frames_ ? gc : nan_;
      const double w = (a == b ? 1 : 2) * species_x_[a] * species_x_[b] * std::pow(sigma_ab, dim_);
      weights += w;
      weighted += w * gc;
    }
  if (!contact_frames_) {
    g_contact_ = z_ = nan_;
    return;
  }
  g_contact_ = weighted / weights;
  z_ = 1 + prefactor * rho * weighted;
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
    if (mixture_) {
      const ContactWindow window{type_.data(), diameter_.data(), types_, ds_, contact_bins_};
      count_pairs(xyz_, dim_, L_, cells_, r_max_, hist_, &window, &contact_hist_);
      ++frames_;
      ++contact_frames_;
      update_mixture_metrics();
    } else {
      count_pairs(xyz_, dim_, L_, cells_, r_max_, hist_);
      ++frames_;
      g_contact_ = contact_value(g(), dr_, sigma_, p_.fit_width);
      z_ = 1 + (dim_ == 2 ? 2 : 4) * eta_ * g_contact_;
    }
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
  if (mixture_) {
    out.put("contact_hist", contact_hist_);
    out.put("contact_frames", contact_frames_);
  }
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
  if (!frames_) g_contact_ = z_ = nan_;  // an older checkpoint's placeholders (0 and 1) before from_step
  if (!mixture_) return;
  // A checkpoint of a run before mixtures were handled: its contact values were of the mean σ;
  // the partial ones count from here.
  if (saved.has("contact_hist")) {
    auto contact = saved.get_vector<std::uint64_t>("contact_hist");
    if (contact.size() != contact_hist_.size())
      throw InputError("observe.gr: the checkpoint's contact histograms have " + std::to_string(contact.size()) +
                       " bins, this pipeline's " + std::to_string(contact_hist_.size()) +
                       " (bins, r_max, fit_width or the species changed)");
    contact_hist_ = std::move(contact);
    contact_frames_ = saved.get<std::uint64_t>("contact_frames");
  } else {
    std::fprintf(info_.messages,
                 "flipflow: warning: observe.gr: the checkpoint has no per-species contact histograms (written "
                 "before mixtures were handled); g_contact and Z count from this continuation on\n");
  }
  update_mixture_metrics();
}

// At each checkpoint too (save_state): a run killed outright (kill -9, the node lost) then
// leaves the g(r) of its newest checkpoint beside it, not only bytes inside the checkpoint.
std::string Gr::write_partial() const {
  const std::string partial = (std::filesystem::path(info_.out_dir) / p_.file).string() + ".partial";
  std::ostringstream out;
  out.precision(17);
  out << "# observe.gr: pair distribution g(r), " << dim_ << "D, N = " << n_ << ", sigma = " << sigma_
      << ", packing_fraction = " << eta_ << ", frames = " << frames_ << "\n";
  if (!mixture_) {
    out << "# g_contact = " << g_contact_ << ", Z = " << z_ << " (1 + " << (dim_ == 2 ? 2 : 4)
        << " eta g_contact)\n";
  } else {
    out << "# g_contact = " << g_contact_ << ", Z = " << z_ << " (mixture: 1 + "
        << (dim_ == 2 ? "(pi rho/2) sum_ij x_i x_j sigma_ij^2" : "(2 pi rho/3) sum_ij x_i x_j sigma_ij^3")
        << " g_ij(sigma_ij+); g_contact is the mean of the g_ij weighted by x_i x_j sigma_ij^" << dim_ << ")\n";
    for (int a = 0; a < types_; ++a)
      for (int b = a; b < types_; ++b)
        out << "# g_contact[" << species_[a] << "," << species_[b] << "] = " << pair_contact(a, b)
            << ", sigma_ij = " << 0.5 * (species_sigma_[a] + species_sigma_[b]) << ", x_i = " << species_x_[a]
            << ", x_j = " << species_x_[b] << "\n";
  }
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
