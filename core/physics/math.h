// Elementary functions written once for the host and CUDA, so that both backends compute the
// same bits. The platforms' own (glibc's libm, CUDA's libdevice) are accurate to an ulp or so but
// not to the same bits, and one differing bit in a trajectory grows until the runs disagree.
//
// musl's fdlibm code (< 1 ulp): log of a positive normal number, the sin/cos kernels on
// [−π/4, π/4] and the Cody–Waite reduction by π/2. Branch-free where a CPU loop runs it over
// vector lanes (core/physics/rng.h's Box–Muller). Only +, −, ×, /, sqrt, rint, floor and bit moves, all
// rounded the same way on both backends, as long as a translation unit does not contract a·b + c
// into one fma: the CPU loops are built with -ffp-contract=off (flipflow_cpu_loop_flags), the
// CUDA loops must be built with -fmad=false (nvcc fuses by default). mul_rn is a product that is
// never fused, for the few spots in CUDA code that keeps contraction (phoretic.forces: its
// all-pairs loop is compute-bound). nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/base/hd.h"

namespace ff::math {

FF_HD std::uint64_t bits_of(double x) {
#if defined(__CUDA_ARCH__)
  return std::uint64_t(__double_as_longlong(x));
#else
  std::uint64_t u;
  std::memcpy(&u, &x, sizeof u);
  return u;
#endif
}

FF_HD double from_bits(std::uint64_t u) {
#if defined(__CUDA_ARCH__)
  return __longlong_as_double(static_cast<long long>(u));
#else
  double x;
  std::memcpy(&x, &u, sizeof x);
  return x;
#endif
}

// a·b rounded by itself: never fused into an fma with an add that follows, even in CUDA code
// compiled with contraction on (the host never fuses: see above).
FF_HD double mul_rn(double a, double b) {
#if defined(__CUDA_ARCH__)
  return __dmul_rn(a, b);
#else
  return a * b;
#endif
}
FF_HD float mul_rn(float a, float b) {
#if defined(__CUDA_ARCH__)
  return __fmul_rn(a, b);
#else
  return a * b;
#endif
}

// log(u) for a normal positive u (musl's fdlibm e_log.c main path, < 1 ulp): u = 2^k (1 + f)
// with 1 + f in [√2/2, √2), log(1 + f) = f − f²/2 + s (f²/2 + R(s²)), s = f / (2 + f).
FF_HD double log_positive(double u) {
  constexpr double ln2_hi = 0x1.62e42fee00000p-1, ln2_lo = 0x1.a39ef35793c76p-33;
  constexpr double Lg1 = 0x1.5555555555593p-1, Lg2 = 0x1.999999997fa04p-2, Lg3 = 0x1.2492494229359p-2,
                   Lg4 = 0x1.c71c51d8e78afp-3, Lg5 = 0x1.7466496cb03dep-3, Lg6 = 0x1.39a09d078c69fp-3,
                   Lg7 = 0x1.2f112df3e5244p-3;
  const std::uint64_t ix = bits_of(u) + (0x3ff0000000000000ull - 0x3fe6a09e00000000ull);
  // k + 1023 is ix's exponent field; 2^52 + (k + 1023) − (2^52 + 1023) is k, exactly.
  const double k = from_bits(0x4330000000000000ull | (ix >> 52)) - 4503599627371519.0;
  const double f = from_bits((ix & 0x000fffffffffffffull) + 0x3fe6a09e00000000ull) - 1.0;
  const double hfsq = 0.5 * f * f;
  const double s = f / (2.0 + f);
  const double z = s * s;
  const double w = z * z;
  const double t1 = w * (Lg2 + w * (Lg4 + w * Lg6));
  const double t2 = z * (Lg1 + w * (Lg3 + w * (Lg5 + w * Lg7)));
  const double R = t2 + t1;
  return s * (hfsq + R) + k * ln2_lo - hfsq + f + k * ln2_hi;
}

// ---- sin and cos ------------------------------------------------------------------------
namespace trig_detail {
constexpr double C1 = 0x1.555555555554cp-5, C2 = -0x1.6c16c16c15177p-10, C3 = 0x1.a01a019cb1590p-16,
                 C4 = -0x1.27e4f809c52adp-22, C5 = 0x1.1ee9ebdb4b1c4p-29, C6 = -0x1.8fae9be8838d4p-37;
constexpr double S1 = -0x1.5555555555549p-3, S2 = 0x1.111111110f8a6p-7, S3 = -0x1.a01a019c161d5p-13,
                 S4 = 0x1.71de357b1fe7dp-19, S5 = -0x1.ae5e68a2b9cebp-26, S6 = 0x1.5d93a5acfd57cp-33;
FF_HD double sin_r(double z, double w) { return S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6); }
FF_HD double cos_r(double z, double w) { return z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6)); }
}  // namespace trig_detail

// musl's __sin / __cos kernels: sin and cos of x for |x| ≤ π/4 (< 1 ulp), x exact ...
FF_HD double kernel_sin(double x) {
  using namespace trig_detail;
  const double z = x * x;
  return x + z * x * (S1 + z * sin_r(z, z * z));
}
FF_HD double kernel_cos(double x) {
  using namespace trig_detail;
  const double z = x * x;
  const double hz = 0.5 * z;
  const double one_minus_hz = 1.0 - hz;
  return one_minus_hz + (((1.0 - one_minus_hz) - hz) + z * cos_r(z, z * z));
}
// ... or of x + y, y the tail of a reduced argument (|y| ≤ ulp(x)/2, rem_pio2).
FF_HD double kernel_sin(double x, double y) {
  using namespace trig_detail;
  const double z = x * x;
  const double v = z * x;
  return x - ((z * (0.5 * y - v * sin_r(z, z * z)) - y) - v * S1);
}
FF_HD double kernel_cos(double x, double y) {
  using namespace trig_detail;
  const double z = x * x;
  const double hz = 0.5 * z;
  const double one_minus_hz = 1.0 - hz;
  return one_minus_hz + (((1.0 - one_minus_hz) - hz) + (z * cos_r(z, z * z) - x * y));
}

// (sin, cos) of n·π/2 + r from sn = sin r and cs = cos r: odd quadrants swap them, sin is
// negative in quadrants 2 and 3, cos in 1 and 2. Arithmetic instead of branches keeps loops over
// lanes vectorizable (×0, ×1 and ×±1 are exact).
FF_HD void quadrant_sincos(int n, double sn, double cs, double& s_out, double& c_out) {
  const int q = n & 3;
  const double odd = double(q & 1);
  const double s_abs = odd * cs + (1.0 - odd) * sn, c_abs = odd * sn + (1.0 - odd) * cs;
  s_out = s_abs * double(1 - (q & 2));
  c_out = c_abs * double(1 - ((q + 1) & 2));
}

// Largest |x| that rem_pio2 reduces correctly: 2^20·π/2 (n·(π/2)'s leading 33 bits exact).
inline constexpr double kRemPio2Max = 1647099.3291652855;

// x = n·π/2 + (y0 + y1) with |y0 + y1| ≲ π/4 and |y1| ≤ ulp(y0)/2; returns n. musl's __rem_pio2
// for |x| < kRemPio2Max (Cody–Waite: π/2 in three 33-bit pieces, the second and third used only
// when the first leaves too few bits, near multiples of π/2). Larger |x| is first reduced exactly
// modulo 2π rounded to double (fmod is exact), so sin/cos there are of x mod 2π̃: the same bits on
// both backends, not the true ones (ABP keeps its angles in [−π, π)). Not finite: y0 = NaN.
FF_HD int rem_pio2(double x, double& y0, double& y1) {
  constexpr double invpio2 = 6.36619772367581382433e-01, pio2_1 = 1.57079632673412561417e+00,
                   pio2_1t = 6.07710050650619224932e-11, pio2_2 = 6.07710050630396597660e-11,
                   pio2_2t = 2.02226624879595063154e-21, pio2_3 = 2.02226624871116645580e-21,
                   pio2_3t = 8.47842766036889956997e-32;
  if (!(std::fabs(x) < kRemPio2Max)) {
    if (!(std::fabs(x) <= 1.7976931348623157e308)) {  // ±inf, NaN
      y0 = x - x;
      y1 = 0;
      return 0;
    }
    x = std::fmod(x, 6.283185307179586);
  }
  const double fn = std::rint(x * invpio2);
  const int n = int(fn);
  double r = x - fn * pio2_1;
  double w = fn * pio2_1t;  // first round: good to 85 bits
  y0 = r - w;
  const int ex = int(bits_of(x) >> 52 & 0x7ff);
  if (ex - int(bits_of(y0) >> 52 & 0x7ff) > 16) {  // second round: good to 118 bits
    double t = r;
    w = fn * pio2_2;
    r = t - w;
    w = fn * pio2_2t - ((t - r) - w);
    y0 = r - w;
    if (ex - int(bits_of(y0) >> 52 & 0x7ff) > 49) {  // third round: 151 bits, every case
      t = r;
      w = fn * pio2_3;
      r = t - w;
      w = fn * pio2_3t - ((t - r) - w);
      y0 = r - w;
    }
  }
  y1 = (r - y0) - w;
  return n;
}

// sin x and cos x (< 1 ulp for |x| < kRemPio2Max; see rem_pio2 beyond), one reduction for both.
FF_HD void sincos(double x, double& s, double& c) {
  double y0, y1;
  const int n = rem_pio2(x, y0, y1);
  quadrant_sincos(n, kernel_sin(y0, y1), kernel_cos(y0, y1), s, c);
}
FF_HD double sin(double x) {
  double s, c;
  sincos(x, s, c);
  return s;
}
FF_HD double cos(double x) {
  double s, c;
  sincos(x, s, c);
  return c;
}

}  // namespace ff::math
