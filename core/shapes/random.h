// Internal to core/shapes and the benchmark's generators (bench/range_scan.h): the random numbers behind the seeded
// shapes and noise, defined by this code alone (the standard distributions are not bit-identical across library
// implementations, and glibc picks among log implementations by CPU features), so every
// generator gives the same bytes on every machine.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

#include "core/vec3.h"

namespace meshsmooth::shapes_internal {

// ln(x) for finite x > 0 from +, -, *, / and frexp alone (core is built without FMA
// contraction, and sqrt is correctly rounded), so noise is the same bytes on every CPU:
// glibc picks among log implementations by CPU features. x = m 2^e with m in
// [sqrt(1/2), sqrt(2)), ln m = 2 atanh(t), t = (m - 1) / (m + 1), |t| < 0.172; the series
// to t^25 is exact to double precision.
inline double PortableLog(double x) {
  int e = 0;
  double m = std::frexp(x, &e);  // m in [0.5, 1)
  if (m < std::numbers::sqrt2 / 2.0) {
    m *= 2.0;
    --e;
  }
  const double t = (m - 1.0) / (m + 1.0), t2 = t * t;
  double sum = 0.0;
  for (int k = 25; k >= 1; k -= 2) sum = sum * t2 + 1.0 / k;
  return 2.0 * t * sum + e * std::numbers::ln2;
}

// splitmix64: a tiny, well-mixed generator whose output is defined by this code alone (the
// standard distributions are not bit-identical across library implementations).
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t Next() {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [-1, 1).
  double NextSigned() { return static_cast<double>(Next() >> 11) * 0x1.0p-52 - 1.0; }
  // Standard normal: Marsaglia's polar method, with PortableLog for the logarithm.
  double NextGaussian() {
    for (;;) {
      const double u = NextSigned(), v = NextSigned(), s = u * u + v * v;
      if (s > 0.0 && s < 1.0) return u * std::sqrt(-2.0 * PortableLog(s) / s);
    }
  }
  // Uniform on the unit sphere: a point of the unit ball by rejection, normalised.
  Vec3 NextDirection() {
    for (;;) {
      const Vec3 p{NextSigned(), NextSigned(), NextSigned()};
      const double s = SquaredNorm(p);
      if (s > 1e-6 && s <= 1.0) return p * (1.0 / std::sqrt(s));
    }
  }

 private:
  uint64_t state_;
};

}  // namespace meshsmooth::shapes_internal
