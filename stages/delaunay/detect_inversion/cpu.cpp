#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <cstring>
#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "core/backend/exec_cpu.h"
#include "stages/delaunay/detect_inversion/stage.h"

namespace ff::delaunay {

namespace {

#if defined(__AVX2__)
// The common case four edges at a time (AVX2; coordinates in double for either precision, as
// Points<R> has them): an edge is quiet when both its triangles close under minimum image, its
// vector did not reverse (r⁰·r¹ >= 0), both its triangles are positive and it is not a Lawson
// candidate (in-circle determinant <= 0). A quiet edge gets mark 0 and nothing else, exactly
// what MarkInversions::test does for it; any other edge goes through test() itself. Every value
// compared is computed with the same operations in the same order as test()'s scalar code (no
// fma in this file), so the two agree bit for bit: quiet here <=> test() would find nothing
// (stages/delaunay/detect_inversion/test_detect_inversion.cpp compares both loops on configurations full of rare
// events, in both precisions).
struct Xy {
  __m256d x, y;
};

// Point i's (x, y) in double (exact for float positions, as Points<R> converts them).
inline __m128d load_xy(const double* p, int i) { return _mm_loadu_pd(p + 2 * i); }
inline __m128d load_xy(const float* p, int i) {
  return _mm_cvtps_pd(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p + 2 * i))));
}

// The coordinates of points idx[0..3] (x, y interleaved), as a lane per point.
template <class R>
inline Xy gather_xy(const R* p, const int* idx) {
  const __m256d t02 = _mm256_insertf128_pd(_mm256_castpd128_pd256(load_xy(p, idx[0])), load_xy(p, idx[2]), 1);
  const __m256d t13 = _mm256_insertf128_pd(_mm256_castpd128_pd256(load_xy(p, idx[1])), load_xy(p, idx[3]), 1);
  return {_mm256_unpacklo_pd(t02, t13), _mm256_unpackhi_pd(t02, t13)};
}

// Points<R>::image, lane by lane: d when |d| <= L/2, else d − L·rint(d/L).
inline __m256d image(__m256d d, __m256d half, __m256d L, __m256d inv_L) {
  const __m256d abs = _mm256_andnot_pd(_mm256_set1_pd(-0.0), d);
  const __m256d wrapped = _mm256_sub_pd(
      d, _mm256_mul_pd(L, _mm256_round_pd(_mm256_mul_pd(d, inv_L), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)));
  return _mm256_blendv_pd(d, wrapped, _mm256_cmp_pd(abs, half, _CMP_GT_OQ));
}

struct Box4 {
  __m256d half[2], L[2], inv_L[2];
  explicit Box4(const PeriodicBox<double>& b) {
    for (int k = 0; k < 2; ++k) {
      half[k] = _mm256_set1_pd(0.5 * b.L[k]);
      L[k] = _mm256_set1_pd(b.L[k]);
      inv_L[k] = _mm256_set1_pd(b.inv_L[k]);
    }
  }
  Xy rel(const Xy& from, const Xy& to) const {
    return {image(_mm256_sub_pd(to.x, from.x), half[0], L[0], inv_L[0]),
            image(_mm256_sub_pd(to.y, from.y), half[1], L[1], inv_L[1])};
  }
  // Whether some lane of v is not its own minimum image (|v_k| > L_k / 2), i.e. rel() would
  // wrap it: rare (edges across the periodic boundary), so the common path skips the rounding.
  __m256d wraps(const Xy& v) const {
    const __m256d sign = _mm256_set1_pd(-0.0);
    return _mm256_or_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign, v.x), half[0], _CMP_GT_OQ),
                        _mm256_cmp_pd(_mm256_andnot_pd(sign, v.y), half[1], _CMP_GT_OQ));
  }
  // is_min_image(v): |v.x| < L/2 and |v.y| < L/2 (a mask)
  __m256d min_image(const Xy& v) const {
    const __m256d sign = _mm256_set1_pd(-0.0);
    return _mm256_and_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign, v.x), half[0], _CMP_LT_OQ),
                         _mm256_cmp_pd(_mm256_andnot_pd(sign, v.y), half[1], _CMP_LT_OQ));
  }
};

inline Xy sub(const Xy& p, const Xy& q) { return {_mm256_sub_pd(p.x, q.x), _mm256_sub_pd(p.y, q.y)}; }
inline __m256d cross(const Xy& p, const Xy& q) {
  return _mm256_sub_pd(_mm256_mul_pd(p.x, q.y), _mm256_mul_pd(p.y, q.x));
}
inline __m256d dot(const Xy& p, const Xy& q) {
  return _mm256_add_pd(_mm256_mul_pd(p.x, q.x), _mm256_mul_pd(p.y, q.y));
}

// Bit k set: edge e + k is quiet (see above).
template <class R>
inline int quiet4(const MarkInversions<R>& f, const Box4& box, int e) {
  int a[4], b[4], c[4], d[4];
  for (int k = 0; k < 4; ++k) {
    const QuadVertices q = quad_vertices(f.mesh, e + k);
    a[k] = q.a;
    b[k] = q.b;
    c[k] = q.c;
    d[k] = q.d;
  }
  const R* p = f.pts.p;
  const Xy pa = gather_xy(p, a), pb = gather_xy(p, b), pc = gather_xy(p, c), pd = gather_xy(p, d);
  Xy ab = sub(pb, pa), ac = sub(pc, pa), ad = sub(pd, pa);  // as Points::rel when nothing wraps
  if (_mm256_movemask_pd(_mm256_or_pd(box.wraps(ab), _mm256_or_pd(box.wraps(ac), box.wraps(ad))))) {
    ab = box.rel(pa, pb);
    ac = box.rel(pa, pc);
    ad = box.rel(pa, pd);
  }
  __m256d quiet = _mm256_and_pd(box.min_image(sub(ac, ab)), box.min_image(sub(ad, ab)));  // closes()
  if (f.prev) {
    const Xy qa = gather_xy(f.prev, a), qb = gather_xy(f.prev, b);
    Xy before = sub(qb, qa);
    if (_mm256_movemask_pd(box.wraps(before))) before = box.rel(qa, qb);
    quiet = _mm256_andnot_pd(_mm256_cmp_pd(dot(before, ab), _mm256_setzero_pd(), _CMP_LT_OQ), quiet);
  }
  const __m256d zero = _mm256_setzero_pd();
  const __m256d left = cross(ab, ac);                                       // orient(o, ab, ac)
  const __m256d right = cross(sub(Xy{zero, zero}, ab), sub(ad, ab));        // orient(ab, o, ad)
  quiet = _mm256_and_pd(quiet, _mm256_and_pd(_mm256_cmp_pd(left, zero, _CMP_GT_OQ),
                                              _mm256_cmp_pd(right, zero, _CMP_GT_OQ)));
  if (f.candidates) {  // incircle_from_a(ab, ac, ad, left, right) > 0 makes a candidate
    const __m256d sum = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dot(ab, ab), cross(ac, ad)),
                                                    _mm256_mul_pd(dot(ac, ac), right)),
                                      _mm256_mul_pd(dot(ad, ad), left));
    const __m256d det = _mm256_sub_pd(zero, sum);  // −sum, exactly
    quiet = _mm256_andnot_pd(_mm256_cmp_pd(det, zero, _CMP_GT_OQ), quiet);
  }
  return _mm256_movemask_pd(quiet);
}
#endif

// MarkInversions over the edges, each task appending its Lawson candidates in batches of up to
// kBatch (one update of the shared counter per batch instead of per candidate). With AVX2, four
// edges at a time where all four are quiet (quiet4), without the scalar test's software prefetch:
// the edges go along a Hilbert curve, so their points are near the ones just read, and the six
// prefetches an edge (with their index loads) cost more than they hid (bench/README.md).
template <class R>
void mark(std::size_t n, const MarkInversions<R>& f, CUstream_st*) {
  constexpr std::size_t kGrain = 2048, kBatch = 256;
  if (f.reset_next) reset_inversion_counters(f.reset_next);  // as the device loop's element 0
  auto run = [&](std::size_t begin, std::size_t end) __attribute__((flatten)) {
    const MarkInversions<R> local = f;  // as cpu_for_each: members stay in registers
    int batch[kBatch];
    unsigned k = 0;
    auto one = [&](std::size_t i) {
      if (!local.test(int(i))) return;
      batch[k++] = int(i);
      if (k == kBatch) {
        local.append(batch, k);
        k = 0;
      }
    };
    std::size_t i = begin;
#if defined(__AVX2__)
    {  // four at a time
      const Box4 box(local.pts.box);
      for (; i + 4 <= end; i += 4) {
        const int quiet = quiet4(local, box, int(i));
        if (quiet == 0xF) {
          std::memset(local.mark + i, 0, 4);
          continue;
        }
        for (int j = 0; j < 4; ++j) {
          if (quiet >> j & 1)
            local.mark[i + std::size_t(j)] = 0;
          else
            one(i + std::size_t(j));
        }
      }
    }
#endif
    for (; i != end; ++i) one(i);
    if (k) local.append(batch, k);
  };
  if (n <= kGrain) return run(0, n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) { run(r.begin(), r.end()); });
}
}  // namespace

template <class R>
DetectInversionLoops<R> detect_inversion_loops(CpuExec) {
  return {&mark<R>, &CpuExec::for_each<CheckInverted<R>>};
}
template DetectInversionLoops<float> detect_inversion_loops<float>(CpuExec);
template DetectInversionLoops<double> detect_inversion_loops<double>(CpuExec);

}  // namespace ff::delaunay
