// A plain 3-vector of doubles for the hot loops: trivially copyable, no allocation,
// laid out as three contiguous doubles so arrays of it are arrays of xyz.
#pragma once

#include <cmath>

namespace meshsmooth {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;

  constexpr Vec3& operator+=(const Vec3& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  constexpr Vec3& operator-=(const Vec3& o) {
    x -= o.x;
    y -= o.y;
    z -= o.z;
    return *this;
  }
  constexpr Vec3& operator*=(double s) {
    x *= s;
    y *= s;
    z *= s;
    return *this;
  }
  friend constexpr Vec3 operator+(Vec3 a, const Vec3& b) { return a += b; }
  friend constexpr Vec3 operator-(Vec3 a, const Vec3& b) { return a -= b; }
  friend constexpr Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
  friend constexpr Vec3 operator*(Vec3 a, double s) { return a *= s; }
  friend constexpr Vec3 operator*(double s, Vec3 a) { return a *= s; }
  friend constexpr bool operator==(const Vec3& a, const Vec3& b) = default;
};

constexpr double Dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double Norm(const Vec3& a) { return std::sqrt(Dot(a, a)); }
constexpr double SquaredNorm(const Vec3& a) { return Dot(a, a); }
// a / |a|; not finite for the zero vector (callers check the norm first, or IsFinite after).
inline Vec3 Normalized(const Vec3& a) { return a * (1.0 / Norm(a)); }
inline bool IsFinite(const Vec3& a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }

// Axis-aligned bounding box of the points added to it; empty (lo > hi) until the first one.
struct BoundingBox {
  Vec3 lo{HUGE_VAL, HUGE_VAL, HUGE_VAL};
  Vec3 hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};

  // Comparisons rather than std::fmin/fmax, which glibc does not inline (a call per coordinate
  // of every vertex). A NaN coordinate is skipped, as fmin/fmax skip it.
  void Add(const Vec3& p) {
    lo = {p.x < lo.x ? p.x : lo.x, p.y < lo.y ? p.y : lo.y, p.z < lo.z ? p.z : lo.z};
    hi = {hi.x < p.x ? p.x : hi.x, hi.y < p.y ? p.y : hi.y, hi.z < p.z ? p.z : hi.z};
  }
  bool empty() const { return !(lo.x <= hi.x); }
  double diagonal() const { return empty() ? 0.0 : Norm(hi - lo); }
  double max_extent() const { return empty() ? 0.0 : std::fmax(hi.x - lo.x, std::fmax(hi.y - lo.y, hi.z - lo.z)); }
};

// The float32 value nearest to each coordinate (what binary PLY, STL and Draco store).
// Through a volatile because g++ 12.2 at -O2 miscompiles the plain
// `p = {float(p.x), float(p.y), float(p.z)}`: its SLP vectoriser drops the double -> float ->
// double round trip of the first two components (seen on this project's toolchain).
inline Vec3 RoundToFloat(const Vec3& p) {
  volatile float x = static_cast<float>(p.x), y = static_cast<float>(p.y), z = static_cast<float>(p.z);
  return {x, y, z};
}

}  // namespace meshsmooth
