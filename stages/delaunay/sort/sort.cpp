#include <cmath>
#include <cstring>

#include "core/base/error.h"
#include "stages/delaunay/build/build.h"
#include "stages/delaunay/common/fields.h"
#include "stages/delaunay/sort/hilbert3.h"
#include "stages/delaunay/sort/stage.h"

namespace ff::delaunay {

std::vector<std::string> sort_particles_hilbert(State& s) {
  if (s.dim() != 2 && s.dim() != 3)
    throw InputError("delaunay.sort: system.dimensions must be 2 or 3 (it is " + std::to_string(s.dim()) + ")");
  if (s.has_field(fields::status)) {
    Field& st = s.field(fields::status);
    st.acquire(Where::host, Mode::read);
    if (st.host<std::int32_t>()[kBuilt])
      throw InputError("delaunay.sort: a triangulation exists already; list delaunay.sort before the stages that "
                       "build one");
  }
  const std::size_t n = s.n();
  Field& pos = s.field(ff::fields::position);
  pos.acquire(Where::host, Mode::read);
  const std::size_t d = std::size_t(s.dim());
  std::vector<double> x(d * n);
  for (std::size_t i = 0; i < d * n; ++i) {
    const double L = s.box.L[i % d];
    const double v = pos.dtype() == DType::f32 ? double(pos.host<float>()[i]) : pos.host<double>()[i];
    x[i] = v - L * std::floor(v / L);
  }
  const std::vector<std::int32_t> rank = d == 2 ? hilbert_ranks(x, s.box.L[0], s.box.L[1]) : hilbert_ranks_3(x);

  std::vector<std::string> done;
  std::vector<unsigned char> tmp;
  for (const std::string& name : s.field_names()) {
    Field& f = s.field(name);
    if (f.count() != n) continue;
    f.acquire(Where::host, Mode::readwrite);
    const std::size_t row = f.bytes() / n;
    const auto* src = static_cast<const unsigned char*>(f.host_raw());
    tmp.resize(f.bytes());
    for (std::size_t i = 0; i < n; ++i) std::memcpy(tmp.data() + std::size_t(rank[i]) * row, src + i * row, row);
    std::memcpy(f.host_raw(), tmp.data(), f.bytes());
    done.push_back(name);
  }
  return done;
}

}  // namespace ff::delaunay
