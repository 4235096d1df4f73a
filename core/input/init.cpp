#include "core/input/init.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/base/error.h"
#include "core/io/h5md_reader.h"
#include "core/physics/rng.h"

namespace ff {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTriangularMaxPhi = 0.9068996821171089;  // π/(2√3)
constexpr double kFccMaxPhi = 0.7404804896930610;         // π/(3√2)
constexpr std::uint64_t kMaxDropsPerParticle = 1000000;   // RSA gives up after this many

// The Philox counter's `step` word says what a draw is for, so the streams never collide:
// (purpose << 48) | index. `particle` is the element (particle or lattice site).
enum class Draw : std::uint64_t { shuffle = 1, drop = 2, reservoir = 3 };
std::uint64_t counter(Draw purpose, std::uint64_t index) {
  return (std::uint64_t(purpose) << 48) | index;
}

// Uniform integer in [0, n): u ∈ (0, 1], so ceil(u·n) − 1 ∈ [0, n − 1].
std::uint64_t uniform_below(RngKey key, std::uint32_t element, std::uint64_t step, std::uint64_t n) {
  const double u = uniform01(key, element, step, 0, 0);
  const auto j = std::uint64_t(std::ceil(u * double(n)));
  return j == 0 ? 0 : std::min(j - 1, n - 1);
}

std::string num(double x, int digits = 4) {
  std::ostringstream os;
  os.precision(digits);
  os << x;
  return os.str();
}

void validate(const SystemSpec& s) {
  if (s.dimensions != 2 && s.dimensions != 3)
    throw InputError("system.dimensions must be 2 or 3, got " + std::to_string(s.dimensions));
  if (s.N == 0) throw InputError("system.N must be at least 1");
  if (s.N > std::uint64_t(std::numeric_limits<std::int32_t>::max()))
    throw InputError("system.N = " + std::to_string(s.N) + " is too large (at most 2^31 - 1)");
  if (!(s.sigma > 0) || !std::isfinite(s.sigma))
    throw InputError("system.sigma must be a positive number, got " + num(s.sigma));
  if (s.types.empty()) throw InputError("system.types must name at least one species");
  double sum = 0;
  for (auto& t : s.types) {
    if (!(t.fraction >= 0) || !std::isfinite(t.fraction))
      throw InputError("system.types: species '" + t.name + "' has fraction " + num(t.fraction) +
                       "; fractions must be non-negative numbers");
    if (!(t.diameter > 0) || !std::isfinite(t.diameter))
      throw InputError("system.types: species '" + t.name + "' has diameter " + num(t.diameter) +
                       "; diameters must be positive numbers");
    sum += t.fraction;
  }
  if (!(sum > 0)) throw InputError("system.types: the species fractions sum to 0");
}

enum class Placement { random, lattice };

Placement placement(const SystemSpec& s) {
  if (s.init == "random") return Placement::random;
  if (s.init == "lattice_sample") return Placement::lattice;
  if (s.init == "triangular_lattice_sample") {
    if (s.dimensions != 2)
      throw InputError("system.init: triangular_lattice_sample is a 2D lattice; with dimensions: 3 "
                       "use init: lattice_sample (simple cubic or fcc)");
    return Placement::lattice;
  }
  throw InputError("system.init: unknown value '" + s.init +
                   "'; expected random, triangular_lattice_sample or lattice_sample");
}

double particle_volume(int dim, double d) {
  return dim == 2 ? kPi * d * d / 4 : kPi * d * d * d / 6;
}

double min_image(double d, double L) { return d - L * std::rint(d / L); }

// Positions are stored in the run's precision; placement and the overlap checks use exactly the
// stored values (and the box edge as the run sees it), so what is checked is what is simulated.
struct Rounding {
  bool f32 = false;
  double value(double x) const { return f32 ? double(float(x)) : x; }
  // Store x ∈ [0, L) and keep it there after rounding.
  double coordinate(double x, double L) const {
    double r = value(x);
    if (r >= L) r = value(r - L);
    return r < 0 ? 0 : r;
  }
  double epsilon() const { return f32 ? 1.1920929e-07 : 2.220446049250313e-16; }
};

// A uniform cell grid over the periodic box, cells at least `reach` wide, so every particle
// within `reach` of a point lies in its cell or an adjacent one. Cells are capped at ~4N so a
// dilute box does not allocate a huge grid.
class CellGrid {
 public:
  CellGrid(int dim, const double* L, double reach, std::size_t n) : dim_(dim), next_(n, -1) {
    std::size_t cells = 1;
    for (int k = 0; k < dim; ++k) {
      nc_[k] = std::max<std::int64_t>(1, std::int64_t(std::floor(L[k] / reach)));
      cells *= std::size_t(nc_[k]);
    }
    const double target = 4.0 * double(n) + 64.0;
    if (double(cells) > target) {
      const double shrink = std::pow(target / double(cells), 1.0 / dim);
      cells = 1;
      for (int k = 0; k < dim; ++k) {
        nc_[k] = std::max<std::int64_t>(1, std::int64_t(std::floor(double(nc_[k]) * shrink)));
        cells *= std::size_t(nc_[k]);
      }
    }
    for (int k = 0; k < dim; ++k) {
      L_[k] = L[k];
      inv_cell_[k] = double(nc_[k]) / L[k];
      // With fewer than 3 cells along an axis, the ±1 neighbours repeat: visit each cell once.
      if (nc_[k] == 1) offsets_[k] = {0};
      else if (nc_[k] == 2) offsets_[k] = {0, 1};
      else offsets_[k] = {-1, 0, 1};
    }
    head_.assign(cells, -1);
  }

  void insert(std::int64_t i, const double* x) {
    const std::size_t c = cell(x);
    next_[std::size_t(i)] = head_[c];
    head_[c] = i;
  }

  // Calls f(j) for every inserted particle in the cells around x; stops when f returns true.
  template <class F>
  bool any_near(const double* x, F&& f) const {
    std::int64_t c[3] = {0, 0, 0};
    for (int k = 0; k < dim_; ++k) c[k] = axis_cell(x[k], k);
    const int oz = dim_ == 3 ? int(offsets_[2].size()) : 1;
    for (int a = 0; a < int(offsets_[0].size()); ++a)
      for (int b = 0; b < int(offsets_[1].size()); ++b)
        for (int e = 0; e < oz; ++e) {
          std::int64_t idx = wrap(c[0] + offsets_[0][a], 0);
          idx = idx * nc_[1] + wrap(c[1] + offsets_[1][b], 1);
          if (dim_ == 3) idx = idx * nc_[2] + wrap(c[2] + offsets_[2][e], 2);
          for (std::int64_t j = head_[std::size_t(idx)]; j >= 0; j = next_[std::size_t(j)])
            if (f(j)) return true;
        }
    return false;
  }

 private:
  std::int64_t axis_cell(double x, int k) const {
    const auto c = std::int64_t(std::floor(x * inv_cell_[k]));
    return std::min<std::int64_t>(std::max<std::int64_t>(c, 0), nc_[k] - 1);
  }
  std::int64_t wrap(std::int64_t c, int k) const { return ((c % nc_[k]) + nc_[k]) % nc_[k]; }
  std::size_t cell(const double* x) const {
    std::int64_t idx = axis_cell(x[0], 0) * nc_[1] + axis_cell(x[1], 1);
    if (dim_ == 3) idx = idx * nc_[2] + axis_cell(x[2], 2);
    return std::size_t(idx);
  }

  int dim_;
  double L_[3] = {0, 0, 0};
  double inv_cell_[3] = {0, 0, 0};
  std::int64_t nc_[3] = {1, 1, 1};
  std::vector<int> offsets_[3];
  std::vector<std::int64_t> head_, next_;
};

// True when particle i at x overlaps particle j: minimum-image distance < (d_i + d_j)/2.
bool overlaps(int dim, const double* L, const double* x, double di, const double* xj, double dj) {
  double r2 = 0;
  for (int k = 0; k < dim; ++k) {
    const double d = min_image(x[k] - xj[k], L[k]);
    r2 += d * d;
  }
  const double contact = 0.5 * (di + dj);
  return r2 < contact * contact;
}

// Random sequential addition, largest particles first.
void place_random(const SystemSpec& s, const double* L, const std::vector<double>& diam,
                  RngKey key, const Rounding& round, double phi, int wall_axis, std::vector<double>& pos) {
  const int dim = s.dimensions;
  const std::size_t n = diam.size();
  const double dmax = *std::max_element(diam.begin(), diam.end());
  CellGrid grid(dim, L, dmax, n);
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return diam[a] > diam[b]; });
  const bool two_d = dim == 2;
  auto too_dense = [&](const std::string& what) {
    return InputError(
        "system.init: random: " + what + ": packing fraction " + num(phi) +
        " is too high for random placement (random sequential addition jams near " +
        (two_d ? "0.547 in 2D" : "0.38 in 3D") + "). " +
        (phi < (two_d ? 0.907 : 0.740)
             ? std::string("Use `init: ") + (two_d ? "triangular_lattice_sample" : "lattice_sample") + "`, which reaches " +
                   (two_d ? "0.907" : "0.740") + ", or lower the packing fraction"
             : std::string("No packing of equal disks or spheres reaches it: lower the packing fraction")) +
        " (system.packing_fraction, or fewer particles in a larger system.box)");
  };
  // Many equal particles cannot be added at random past the jamming density (0.547 / 0.384 for
  // an infinite system), however many tries are made: say so at once rather than after minutes
  // of drops. The margin covers a finite system's fluctuations; a few particles, or a mixture
  // (larger first, which may pack denser), are left to try.
  const bool equal = *std::min_element(diam.begin(), diam.end()) == dmax;
  if (equal && n >= 1000 && phi > (two_d ? 0.56 : 0.40)) throw too_dense("refused before placing any particle");
  for (std::size_t placed = 0; placed < n; ++placed) {
    const std::size_t i = order[placed];
    double x[3] = {0, 0, 0};
    bool ok = false;
    for (std::uint64_t t = 0; t < kMaxDropsPerParticle && !ok; ++t) {
      for (int k = 0; k < dim; ++k) {
        const double u = uniform01(key, std::uint32_t(i), counter(Draw::drop, t), 0, std::uint32_t(k));
        // 1 − u ∈ [0, 1); between walls, [d_i/2, L − d_i/2) (a centre closer than d_i/2 to a wall
        // would be pushed off it by the first correction, a jump of up to d_i/2).
        x[k] = k == wall_axis ? round.coordinate(0.5 * diam[i] + (1.0 - u) * (L[k] - diam[i]), L[k])
                              : round.coordinate((1.0 - u) * L[k], L[k]);
      }
      ok = !grid.any_near(x, [&](std::int64_t j) {
        return overlaps(dim, L, x, diam[i], &pos[std::size_t(j) * dim], diam[std::size_t(j)]);
      });
    }
    if (!ok) throw too_dense("could not place particle " + std::to_string(placed + 1) + " of " + std::to_string(n) +
                             " without overlap after " + std::to_string(kMaxDropsPerParticle) + " tries");
    for (int k = 0; k < dim; ++k) pos[i * dim + std::size_t(k)] = x[k];
    grid.insert(std::int64_t(i), x);
  }
}

// ---- lattices -------------------------------------------------------------------------------

enum class LatticeKind { triangular, simple_cubic, fcc };

struct LatticePlan {
  LatticeKind kind = LatticeKind::triangular;
  std::uint64_t n[3] = {1, 1, 1};  // triangular: columns, rows; cubic: cells per axis
  double spacing = 0;              // smallest minimum-image distance between two sites
  std::uint64_t sites() const {
    const std::uint64_t cells = n[0] * n[1] * n[2];
    return kind == LatticeKind::fcc ? 4 * cells : cells;
  }
};

std::uint64_t ceil_div(std::uint64_t a, std::uint64_t b) { return (a + b - 1) / b; }

// Upper end of the search along an axis: twice the ideal number of sites along it.
std::uint64_t search_limit(double L, double site_density_1d, std::uint64_t n_min) {
  return std::min<std::uint64_t>(n_min, std::uint64_t(std::ceil(2.0 * L * site_density_1d)) + 2);
}

// Triangular lattice: nx columns (spacing ax), ny rows (spacing ay), odd rows shifted by ax/2.
// Smallest periodic distance, wrap-around included: along a row ax; adjacent rows
// hypot(ax/2, ay); with ny even the last row is shifted and meets row 0 like any adjacent row,
// and a row meets its own image (or the row two down, same offset) at 2ay; with ny odd the last
// row and row 0 are both unshifted, ay apart (ny = 1: a row meets its own image at Ly = ay).
double triangular_spacing(double ax, double ay, std::uint64_t ny) {
  double d = ax;
  if (ny >= 2) d = std::min(d, std::hypot(0.5 * ax, ay));
  d = std::min(d, ny % 2 == 0 ? 2.0 * ay : ay);
  return d;
}

LatticePlan best_lattice(const Box& box, std::uint64_t n_min) {
  LatticePlan best;
  best.spacing = -1;
  const double* L = box.L;
  if (box.dim == 2) {
    // Ideal triangular lattice of n_min sites: area per site (√3/2) a².
    const double a = std::sqrt(2.0 * L[0] * L[1] / (std::sqrt(3.0) * double(n_min)));
    const std::uint64_t ny_hi = search_limit(L[1], 1.0 / (0.8660254037844386 * a), n_min);
    for (std::uint64_t ny = 1; ny <= ny_hi; ++ny) {
      const std::uint64_t nx = ceil_div(n_min, ny);
      const double d = triangular_spacing(L[0] / double(nx), L[1] / double(ny), ny);
      if (d > best.spacing) {
        best.kind = LatticeKind::triangular;
        best.n[0] = nx, best.n[1] = ny, best.n[2] = 1;
        best.spacing = d;
      }
    }
    return best;
  }
  // 3D: simple cubic (1 site per cell) and fcc (4 per cell), cells ax × ay × az. fcc sites
  // (0,0,0), (½,½,0), (½,0,½), (0,½,½): nearest distances hypot(a_i, a_j)/2 and, to the same
  // site in the next cell (its own image when n = 1), a_i.
  const double V = box.volume();
  for (LatticeKind kind : {LatticeKind::fcc, LatticeKind::simple_cubic}) {
    const std::uint64_t per_cell = kind == LatticeKind::fcc ? 4 : 1;
    const std::uint64_t cells_min = ceil_div(n_min, per_cell);
    const double density_1d = std::cbrt(double(cells_min) / V);
    const std::uint64_t nx_hi = search_limit(L[0], density_1d, cells_min);
    const std::uint64_t ny_hi = search_limit(L[1], density_1d, cells_min);
    for (std::uint64_t nx = 1; nx <= nx_hi; ++nx)
      for (std::uint64_t ny = 1; ny <= ny_hi; ++ny) {
        const std::uint64_t nz = ceil_div(cells_min, nx * ny);
        const double ax = L[0] / double(nx), ay = L[1] / double(ny), az = L[2] / double(nz);
        double d = std::min({ax, ay, az});
        if (kind == LatticeKind::fcc)
          d = std::min({d, 0.5 * std::hypot(ax, ay), 0.5 * std::hypot(ax, az), 0.5 * std::hypot(ay, az)});
        if (d > best.spacing) {
          best.kind = kind;
          best.n[0] = nx, best.n[1] = ny, best.n[2] = nz;
          best.spacing = d;
        }
      }
  }
  return best;
}

std::vector<std::array<double, 3>> generate(const Box& box, const LatticePlan& plan) {
  std::vector<std::array<double, 3>> sites;
  sites.reserve(std::size_t(plan.sites()));
  const double a[3] = {box.L[0] / double(plan.n[0]), box.L[1] / double(plan.n[1]),
                       box.dim == 3 ? box.L[2] / double(plan.n[2]) : 0.0};
  if (plan.kind == LatticeKind::triangular) {
    for (std::uint64_t r = 0; r < plan.n[1]; ++r)
      for (std::uint64_t c = 0; c < plan.n[0]; ++c)
        sites.push_back({(double(c) + 0.5 * double(r % 2)) * a[0], double(r) * a[1], 0.0});
    return sites;
  }
  static const double kFccBasis[4][3] = {{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 0, 0.5}, {0, 0.5, 0.5}};
  const int basis = plan.kind == LatticeKind::fcc ? 4 : 1;
  for (std::uint64_t i = 0; i < plan.n[0]; ++i)
    for (std::uint64_t j = 0; j < plan.n[1]; ++j)
      for (std::uint64_t k = 0; k < plan.n[2]; ++k)
        for (int b = 0; b < basis; ++b)
          sites.push_back({(double(i) + kFccBasis[b][0]) * a[0], (double(j) + kFccBasis[b][1]) * a[1],
                           (double(k) + kFccBasis[b][2]) * a[2]});
  return sites;
}

const char* lattice_name(int dim) { return dim == 2 ? "triangular" : "fcc or simple cubic"; }

// N of the M lattice sites by reservoir sampling (Vitter's Algorithm R), in site order.
void place_on_lattice(const SystemSpec& s, const Box& box, const std::vector<double>& diam,
                      RngKey key, const Rounding& round, double phi, std::vector<double>& pos) {
  const int dim = s.dimensions;
  const std::size_t n = diam.size();
  const double dmax = *std::max_element(diam.begin(), diam.end());
  const LatticePlan plan = best_lattice(box, n);
  // Rounding positions to the run's precision moves them by up to ~eps·L: keep that much room.
  const double L_max = *std::max_element(box.L, box.L + dim);
  const double need = dmax * (1.0 + 8.0 * round.epsilon() * std::max(1.0, L_max / dmax));
  if (plan.spacing < need) {
    const double reachable = phi * std::pow(plan.spacing / need, dim);
    throw InputError(
        "system.init: " + s.init + ": packing fraction " + num(phi) + " is too dense for " + std::string(dim == 2 ? "a " : "an ") +
        lattice_name(dim) + " lattice: with at least " + std::to_string(n) +
        " sites in this box the nearest-neighbour distance is at most " + num(plan.spacing) +
        ", below the largest diameter " + num(dmax) + ". The maximum packing fraction of a " +
        (dim == 2 ? "triangular lattice is π/(2√3) ≈ 0.9069" : "fcc lattice is π/(3√2) ≈ 0.7405") +
        " for equal particles; with this N, box and largest diameter it is ≈ " + num(reachable) +
        ". Lower system.packing_fraction or enlarge system.box");
  }
  const std::uint64_t m = plan.sites();
  if (m > std::numeric_limits<std::uint32_t>::max())
    throw InputError("system.init: lattice of " + std::to_string(m) + " sites is too large");
  const auto sites = generate(box, plan);
  std::vector<std::uint64_t> chosen(n);
  std::iota(chosen.begin(), chosen.end(), std::uint64_t(0));
  for (std::uint64_t i = n; i < m; ++i) {
    const std::uint64_t j = uniform_below(key, std::uint32_t(i), counter(Draw::reservoir, 0), i + 1);
    if (j < n) chosen[std::size_t(j)] = i;
  }
  std::sort(chosen.begin(), chosen.end());  // neighbouring particles get neighbouring indices
  for (std::size_t p = 0; p < n; ++p)
    for (int k = 0; k < dim; ++k)
      pos[p * dim + std::size_t(k)] = round.coordinate(sites[std::size_t(chosen[p])][std::size_t(k)], box.L[k]);
}

// Species of each particle: counts[k] of species k, in a seeded Fisher–Yates order.
std::vector<std::int32_t> shuffled_types(const std::vector<std::uint64_t>& counts, RngKey key) {
  std::vector<std::int32_t> type;
  for (std::size_t k = 0; k < counts.size(); ++k) type.insert(type.end(), std::size_t(counts[k]), std::int32_t(k));
  for (std::size_t i = type.size(); i-- > 1;) {
    const auto j = std::size_t(uniform_below(key, std::uint32_t(i), counter(Draw::shuffle, 0), i + 1));
    std::swap(type[i], type[j]);
  }
  return type;
}

// An overlap here is a bug in this file, never the user's fault.
void check_no_overlap(int dim, const double* L, const std::vector<double>& pos,
                      const std::vector<double>& diam) {
  const std::size_t n = diam.size();
  CellGrid grid(dim, L, *std::max_element(diam.begin(), diam.end()), n);
  for (std::size_t i = 0; i < n; ++i) {
    const double* x = &pos[i * dim];
    std::int64_t hit = -1;
    grid.any_near(x, [&](std::int64_t j) {
      if (!overlaps(dim, L, x, diam[i], &pos[std::size_t(j) * dim], diam[std::size_t(j)])) return false;
      hit = j;
      return true;
    });
    if (hit >= 0)
      throw std::logic_error("initial state: particles " + std::to_string(hit) + " and " +
                             std::to_string(i) + " overlap (a bug in core/input/init.cpp)");
    grid.insert(std::int64_t(i), x);
  }
}

template <class R>
void write_fields(State& st, const std::vector<double>& pos, const std::vector<std::int32_t>& type,
                  const std::vector<double>& diam) {
  Field& fp = st.field(fields::position);
  Field& fi = st.field(fields::image);
  Field& ft = st.field(fields::type);
  Field& fd = st.field(fields::diameter);
  for (Field* f : {&fp, &fi, &ft, &fd}) f->acquire(Where::host, Mode::write);
  R* p = fp.host<R>();
  for (std::size_t i = 0; i < pos.size(); ++i) p[i] = R(pos[i]);
  std::int32_t* img = fi.host<std::int32_t>();
  std::fill(img, img + fi.size(), 0);
  std::copy(type.begin(), type.end(), ft.host<std::int32_t>());
  R* d = fd.host<R>();
  for (std::size_t i = 0; i < diam.size(); ++i) d[i] = R(diam[i]);
}

}  // namespace

std::vector<std::uint64_t> species_counts(const SystemSpec& s) {
  validate(s);
  const std::size_t K = s.types.size();
  double total = 0;
  for (auto& t : s.types) total += t.fraction;
  std::vector<double> exact(K);
  std::vector<std::int64_t> count(K);
  std::int64_t sum = 0;
  for (std::size_t k = 0; k < K; ++k) {
    exact[k] = s.types[k].fraction / total * double(s.N);
    count[k] = std::llround(exact[k]);
    sum += count[k];
  }
  const auto N = std::int64_t(s.N);
  while (sum > N) {  // take one from the species rounded up the most
    std::size_t pick = K;
    for (std::size_t k = 0; k < K; ++k)
      if (count[k] > 0 && (pick == K || count[k] - exact[k] > count[pick] - exact[pick])) pick = k;
    --count[pick], --sum;
  }
  while (sum < N) {  // give one to the species rounded down the most
    std::size_t pick = 0;
    for (std::size_t k = 1; k < K; ++k)
      if (exact[k] - count[k] > exact[pick] - count[pick]) pick = k;
    ++count[pick], ++sum;
  }
  return std::vector<std::uint64_t>(count.begin(), count.end());
}

Box make_box(const SystemSpec& s) {
  validate(s);
  Box box;
  box.dim = s.dimensions;
  if (!s.box.empty()) {
    if (int(s.box.size()) != s.dimensions)
      throw InputError("system.box must have " + std::to_string(s.dimensions) +
                       " edge lengths (one per dimension), got " + std::to_string(s.box.size()));
    for (std::size_t k = 0; k < s.box.size(); ++k) {
      if (!(s.box[k] > 0) || !std::isfinite(s.box[k]))
        throw InputError("system.box: edge " + std::to_string(k) + " is " + num(s.box[k]) +
                         "; edges must be positive numbers");
      box.L[k] = s.box[k];
    }
    return box;
  }
  if (!(s.packing_fraction > 0 && s.packing_fraction < 1))
    throw InputError("system.packing_fraction must be between 0 and 1 when system.box is not given, got " +
                     num(s.packing_fraction));
  const auto counts = species_counts(s);
  double occupied = 0;
  for (std::size_t k = 0; k < counts.size(); ++k)
    occupied += double(counts[k]) * particle_volume(s.dimensions, s.sigma * s.types[k].diameter);
  const double L = std::pow(occupied / s.packing_fraction, 1.0 / s.dimensions);
  for (int k = 0; k < s.dimensions; ++k) box.L[k] = L;
  return box;
}

std::vector<std::array<double, 3>> lattice_sites(const Box& box, std::uint64_t n_min, double& spacing) {
  const LatticePlan plan = best_lattice(box, std::max<std::uint64_t>(n_min, 1));
  spacing = plan.spacing;
  return generate(box, plan);
}

namespace {

// system.init: {from: FILE.h5, frame: k}: the box, positions, images, species and (when the
// file has them) orientations of one frame; diameters from system.types as for any run.
std::unique_ptr<State> state_from_h5md(const SystemSpec& s, Precision precision) {
  validate(s);
  const H5mdFrame fr = read_h5md_frame(s.init_from, s.init_frame);
  const std::string what = "system.init.from: '" + s.init_from + "' frame " + std::to_string(fr.frame) + " (step " +
                           std::to_string(fr.step) + ")";
  if (fr.dim != s.dimensions)
    throw InputError(what + " is " + std::to_string(fr.dim) + "D; system.dimensions is " +
                     std::to_string(s.dimensions));
  if (fr.n != s.N)
    throw InputError(what + " has " + std::to_string(fr.n) + " particles; system.N is " + std::to_string(s.N) +
                     ": set N: " + std::to_string(fr.n));
  if (!s.box.empty() || s.packing_fraction > 0) {
    const Box want = make_box(s);
    for (int k = 0; k < s.dimensions; ++k)
      if (std::abs(want.L[k] - fr.edges[k]) > 1e-9 * fr.edges[k])
        throw InputError(what + " has box edge " + num(fr.edges[k]) + " along axis " + std::to_string(k) +
                         "; system." + (s.box.empty() ? "packing_fraction" : "box") + " gives " + num(want.L[k]) +
                         ": remove it (the file's box is used)");
  }
  if (!fr.species_names.empty()) {
    for (std::size_t k = 0; k < fr.species_names.size() && k < s.types.size(); ++k)
      if (fr.species_names[k] != s.types[k].name)
        throw InputError(what + ": its species " + std::to_string(k) + " is '" + fr.species_names[k] +
                         "', system.types names '" + s.types[k].name + "' there: list the same species in order");
  }
  for (std::size_t i = 0; i < fr.n; ++i)
    if (fr.species[i] < 0 || std::size_t(fr.species[i]) >= s.types.size())
      throw InputError(what + ": particle " + std::to_string(i) + " has species " + std::to_string(fr.species[i]) +
                       ", but system.types lists " + std::to_string(s.types.size()));
  const Rounding round{precision == Precision::f32};
  auto state = std::make_unique<State>(s.dimensions, precision, std::size_t(s.N));
  state->box.dim = s.dimensions;
  for (int k = 0; k < s.dimensions; ++k) state->box.L[k] = round.value(fr.edges[k]);
  for (auto& t : s.types) {
    state->species.push_back(t.name);
    state->species_diameter.push_back(s.sigma * t.diameter);
  }
  std::vector<double> diam(fr.n);
  for (std::size_t i = 0; i < fr.n; ++i) diam[i] = state->species_diameter[std::size_t(fr.species[i])];
  if (precision == Precision::f32) write_fields<float>(*state, fr.position, fr.species, diam);
  else write_fields<double>(*state, fr.position, fr.species, diam);
  Field& img = state->field(fields::image);
  std::copy(fr.image.begin(), fr.image.end(), img.host<std::int32_t>());
  if (!fr.orientation.empty()) {
    // abp.integrate keeps an orientation field that exists (and checks its shape).
    Field& o = state->add_particle_field("orientation", state->real(), fr.orientation_components);
    o.acquire(Where::host, Mode::write);
    for (std::size_t k = 0; k < fr.orientation.size(); ++k) {
      if (precision == Precision::f32) o.host<float>()[k] = float(fr.orientation[k]);
      else o.host<double>()[k] = fr.orientation[k];
    }
  }
  return state;
}

}  // namespace

std::unique_ptr<State> make_initial_state(const SystemSpec& s, Precision precision, std::uint64_t seed,
                                          int wall_axis) {
  if (s.init == "from") return state_from_h5md(s, precision);
  const Box box = make_box(s);  // validates s
  const Placement how = placement(s);
  const auto counts = species_counts(s);
  const int dim = s.dimensions;
  const std::size_t n = std::size_t(s.N);

  // The box edge as the run's precision sees it: stored that way, so placement, the overlap
  // check and every later minimum image use the same numbers.
  const Rounding round{precision == Precision::f32};
  Box seen = box;
  for (int k = 0; k < dim; ++k) seen.L[k] = round.value(box.L[k]);

  auto state = std::make_unique<State>(dim, precision, n);
  state->box = seen;
  for (auto& t : s.types) {
    state->species.push_back(t.name);
    state->species_diameter.push_back(s.sigma * t.diameter);
  }

  const RngKey key = make_rng_key(seed, "init");
  const std::vector<std::int32_t> type = shuffled_types(counts, key);
  std::vector<double> diam(n);
  double occupied = 0;
  for (std::size_t i = 0; i < n; ++i) {
    diam[i] = state->species_diameter[std::size_t(type[i])];
    occupied += particle_volume(dim, diam[i]);
  }
  const double phi = occupied / seen.volume();

  std::vector<double> pos(n * std::size_t(dim));
  if (how == Placement::random) place_random(s, seen.L, diam, key, round, phi, wall_axis < dim ? wall_axis : -1, pos);
  else place_on_lattice(s, seen, diam, key, round, phi, pos);
  check_no_overlap(dim, seen.L, pos, diam);

  if (precision == Precision::f32) write_fields<float>(*state, pos, type, diam);
  else write_fields<double>(*state, pos, type, diam);
  return state;
}

}  // namespace ff
