// Shared by the enhancement tests (core and service): the unit icosphere with a spherical-harmonic
// bump along its normals, the least-squares fit of its radius and bump amplitude, and the faces a
// run turned over.
#pragma once

#include <cstdint>

#include "core/mesh.h"
#include "core/shapes/parametric.h"
#include "core/vec3.h"

namespace meshsmooth::testing {

// Re((x + i y)^l) on the unit sphere: a spherical harmonic of degree l.
inline double Harmonic(const Vec3& u, int l) {
  double re = 1.0, im = 0.0;
  for (int k = 0; k < l; ++k) {
    const double next = re * u.x - im * u.y;
    im = re * u.y + im * u.x;
    re = next;
  }
  return re;
}

// The unit icosphere with a bump eps Y_l along its normals.
inline Mesh BumpySphere(int level, int l, double eps) {
  Mesh m = Icosphere(level);
  for (Vec3& p : m.positions) p = p * (1.0 + eps * Harmonic(p, l));
  return m;
}

struct BumpFit {
  double radius = 0.0, amplitude = 0.0;
};

// Least squares of |p| = radius + amplitude Y_l(p / |p|) over the vertices.
inline BumpFit FitBump(const Mesh& m, int l) {
  double s11 = 0, s1y = 0, syy = 0, sr = 0, sry = 0;
  for (const Vec3& p : m.positions) {
    const double r = Norm(p), y = Harmonic(p * (1.0 / r), l);
    s11 += 1, s1y += y, syy += y * y, sr += r, sry += r * y;
  }
  const double det = s11 * syy - s1y * s1y;
  return {(sr * syy - sry * s1y) / det, (s11 * sry - s1y * sr) / det};
}

// Faces whose normal turned by 90 degrees or more from `before` to `after`.
inline int64_t FlippedFaces(const Mesh& before, const Mesh& after) {
  int64_t flipped = 0;
  for (const Triangle& t : before.triangles) {
    auto normal = [&](const Mesh& m) {
      return Cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]);
    };
    flipped += Dot(normal(before), normal(after)) <= 0.0;
  }
  return flipped;
}

}  // namespace meshsmooth::testing
