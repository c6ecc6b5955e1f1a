#include "core/features/curvature.h"

#include <atomic>
#include <cmath>
#include <vector>

namespace meshsmooth {
namespace {

// Below these relative sizes a normal or an edge is numerically zero: the vertex (normal) or
// the face (edge) is left out rather than divided by ~0.
constexpr double kTinyNormal = 1e-12;  // |sum of weighted face normals| vs their total length
constexpr double kTinyEdge = 1e-24;    // |edge|^2 vs sum of |edge|^2 around the vertex
// A face whose least-squares system (eq. (8) of Rusinkiewicz 2004) has a determinant below this
// fraction of its scale (sum of |edge|^2, cubed) is a sliver: it is left out.
constexpr double kTinySystem = 1e-12;

// Below this many vertices the OpenMP team costs more than the loop.
constexpr int32_t kParallelMin = 4096;

// The unit normal at v after Max ("Weights for computing vertex normals from facet normals",
// 1999): the sum of the face cross products (Q_k - P) x (Q_k+1 - P) weighted by
// 1 / (|Q_k - P|^2 |Q_k+1 - P|^2), exact for any triangulation of points on a sphere. Faces with
// a non-finite or coincident corner are left out; zero where nothing is left.
Vec3 VertexNormal(const Mesh& mesh, const Topology& topo, int32_t v) {
  const VertexKind kind = topo.kind[v];
  if (kind != VertexKind::kInterior && kind != VertexKind::kBoundary) return {};
  const int32_t* ring = topo.ring.data() + topo.ring_offsets[v];
  const int32_t n = topo.valence(v);
  const Vec3 p = mesh.positions[v];
  if (!IsFinite(p) || n < 2) return {};
  double sum_len2 = 0.0;
  for (int32_t k = 0; k < n; ++k) {
    const Vec3& q = mesh.positions[ring[k]];
    if (IsFinite(q)) sum_len2 += SquaredNorm(q - p);
  }
  if (!(sum_len2 > 0.0) || !std::isfinite(sum_len2)) return {};
  const int32_t faces = kind == VertexKind::kInterior ? n : n - 1;
  Vec3 sum;
  double length = 0.0;  // L1 lengths: only the scale of the cancellation test
  for (int32_t k = 0; k < faces; ++k) {
    const Vec3 a = mesh.positions[ring[k]] - p, b = mesh.positions[ring[k + 1 == n ? 0 : k + 1]] - p;
    const double la = SquaredNorm(a), lb = SquaredNorm(b);
    if (!IsFinite(a) || !IsFinite(b) || !(la > kTinyEdge * sum_len2) || !(lb > kTinyEdge * sum_len2)) continue;
    // Scaled by sum_len2 so that the weights stay near 1 whatever the mesh's units.
    const Vec3 c = Cross(a, b) * (sum_len2 * sum_len2 / (la * lb));
    sum += c;
    length += std::abs(c.x) + std::abs(c.y) + std::abs(c.z);
  }
  if (!(Norm(sum) > kTinyNormal * length)) return {};
  const Vec3 normal = Normalized(sum);
  return IsFinite(normal) ? normal : Vec3{};
}

// The share of the face (P, Q1, Q2) that belongs to P: its Voronoi region when the triangle is
// not obtuse, else half the area when the angle at P is obtuse and a quarter otherwise (the
// "mixed area" of Meyer et al. 2002, the weights of Section 3.3 of Rusinkiewicz 2004).
double MixedArea(const Vec3& a, const Vec3& b, double area2) {  // a = Q1 - P, b = Q2 - P, area2 = |a x b|
  const Vec3 c = b - a;
  const double at_p = Dot(a, b), at_q1 = -Dot(a, c), at_q2 = Dot(b, c);
  if (at_p < 0.0) return 0.25 * area2;
  if (at_q1 < 0.0 || at_q2 < 0.0) return 0.125 * area2;
  return (SquaredNorm(a) * at_q2 + SquaredNorm(b) * at_q1) / (8.0 * area2);
}

struct VertexEstimate {
  Vec3 dir_max, dir_min;
  double kmax = 0.0, kmin = 0.0;
  bool valid = false;
};

// Rusinkiewicz 2004 at the interior vertex v. For each incident face (P, Q_k, Q_k+1): the
// vertex frame (t1, t2) is carried into the face's plane by the minimal rotation that takes N to
// the face normal (Section 3.2; II does not change under it), and there the symmetric II is the
// least-squares solution of II e_i = (the normal change along e_i) over the face's three edges
// (eq. (8): six equations, three unknowns). The faces' II are averaged with the corner's mixed
// area as weight (Section 3.3) and the average is diagonalised.
VertexEstimate EstimateAt(const Mesh& mesh, const Topology& topo, const std::vector<Vec3>& normals, int32_t v) {
  VertexEstimate out;
  const Vec3 normal = normals[v];
  const int32_t n = topo.valence(v);
  if (topo.kind[v] != VertexKind::kInterior || n < 3 || normal == Vec3{}) return out;
  const int32_t* ring = topo.ring.data() + topo.ring_offsets[v];
  const Vec3 p = mesh.positions[v];

  // Householder reflection Q = I - 2 W W^T with Q e1 = +-N (sign chosen against
  // cancellation); its second and third columns span the tangent plane.
  const Vec3 e1{1.0, 0.0, 0.0};
  const Vec3 minus = e1 - normal, plus = e1 + normal;
  const Vec3 w = Normalized(SquaredNorm(minus) > SquaredNorm(plus) ? minus : plus);
  const Vec3 t1 = Vec3{0.0, 1.0, 0.0} - w * (2.0 * w.y);
  const Vec3 t2 = Vec3{0.0, 0.0, 1.0} - w * (2.0 * w.z);

  // Two sums: the faces whose corners are all interior, and the others. A boundary vertex's
  // normal comes from a one-sided fan and is tilted where the surface bends, so its faces
  // count only when the vertex has no other (measured on the cosine wave: counted, they put a
  // row next to a boundary crest 20% low and make a false ridge beside it).
  double sums[2][4] = {};  // b11, b12, b22, weight sum
  for (int32_t k = 0; k < n; ++k) {
    const int32_t qa = ring[k], qb = ring[k + 1 == n ? 0 : k + 1];
    const Vec3 na = normals[qa], nb = normals[qb];
    if (na == Vec3{} || nb == Vec3{}) continue;  // a corner without a normal
    double* sum = sums[topo.kind[qa] == VertexKind::kInterior && topo.kind[qb] == VertexKind::kInterior ? 0 : 1];
    const Vec3 a = mesh.positions[qa] - p, b = mesh.positions[qb] - p;
    const Vec3 cross = Cross(a, b);
    const double area2 = Norm(cross);
    if (!(area2 > 0.0) || !std::isfinite(area2)) continue;
    const double weight = MixedArea(a, b, area2);
    if (!(weight > 0.0)) continue;
    // II depends on the face's plane alone: its normal is taken on N's side (faces of an
    // inconsistently oriented mesh too).
    Vec3 nf = cross * (1.0 / area2);
    double ndot = Dot(nf, normal);
    if (ndot < 0.0) {
      nf = nf * -1.0;
      ndot = -ndot;
    }
    const Vec3 perp = nf - normal * ndot, dperp = (normal + nf) * (1.0 / (1.0 + ndot));
    const Vec3 x1 = t1 - dperp * Dot(perp, t1), x2 = t2 - dperp * Dot(perp, t2);
    // The edges Q_k - P, Q_k+1 - Q_k, P - Q_k+1 and the normal changes along them (each triple
    // sums to zero, so the third's coordinates follow from the first two); normal equations
    // M (xx xy yy)^T = r of the rows (u w 0) -> dn.x1 and (0 u w) -> dn.x2.
    const Vec3 c = b - a, dc = nb - na, dan = na - normal;
    const double u[3] = {Dot(a, x1), Dot(c, x1), 0.0}, wv[3] = {Dot(a, x2), Dot(c, x2), 0.0};
    const double d1[3] = {Dot(dan, x1), Dot(dc, x1), 0.0}, d2[3] = {Dot(dan, x2), Dot(dc, x2), 0.0};
    double m11 = 0.0, m12 = 0.0, m33 = 0.0, r1 = 0.0, r2 = 0.0, r3 = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double ui = i < 2 ? u[i] : -(u[0] + u[1]), wi = i < 2 ? wv[i] : -(wv[0] + wv[1]);
      const double d1i = i < 2 ? d1[i] : -(d1[0] + d1[1]), d2i = i < 2 ? d2[i] : -(d2[0] + d2[1]);
      m11 += ui * ui;
      m12 += ui * wi;
      m33 += wi * wi;
      r1 += ui * d1i;
      r2 += wi * d1i + ui * d2i;
      r3 += wi * d2i;
    }
    // M = (m11 m12 0; m12 m11+m33 m12; 0 m12 m33), solved by its cofactors.
    const double m22 = m11 + m33;
    const double c11 = m22 * m33 - m12 * m12, c12 = -m12 * m33, c13 = m12 * m12;
    const double c22 = m11 * m33, c23 = -m11 * m12, c33 = m11 * m22 - m12 * m12;
    const double det = m11 * c11 + m12 * c12;
    if (!(det > kTinySystem * m22 * m22 * m22)) continue;  // a sliver: its edges span no plane
    const double inv = weight / det;
    sum[0] += (c11 * r1 + c12 * r2 + c13 * r3) * inv;
    sum[1] += (c12 * r1 + c22 * r2 + c23 * r3) * inv;
    sum[2] += (c13 * r1 + c23 * r2 + c33 * r3) * inv;
    sum[3] += weight;
  }
  const double* sum = sums[sums[0][3] > 0.0 ? 0 : 1];
  const double weight_sum = sum[3];
  if (!(weight_sum > 0.0)) return out;  // every incident face has zero area or no normals
  const double inv_w = 1.0 / weight_sum;
  const double b11 = sum[0] * inv_w, b12 = sum[1] * inv_w, b22 = sum[2] * inv_w;

  // Symmetric 2x2 eigen-decomposition: kmax = mean + radius, its eigenvector from the row of
  // B - kmax I with the larger entries (the other row is parallel to it).
  const double mean = 0.5 * (b11 + b22), half = 0.5 * (b11 - b22);
  const double radius = std::sqrt(half * half + b12 * b12);
  out.kmax = mean + radius;
  out.kmin = mean - radius;
  // (b12, kmax - b11) = (b12, radius - half) and (kmax - b22, b12) = (radius + half, b12).
  const double a = half >= 0.0 ? radius + half : b12, c = half >= 0.0 ? b12 : radius - half;
  const double len = std::sqrt(a * a + c * c);
  out.dir_max = len > 0.0 ? (t1 * a + t2 * c) * (1.0 / len) : t1;  // B = mean I: any direction
  out.dir_min = Cross(normal, out.dir_max);
  out.valid = std::isfinite(out.kmax) && std::isfinite(out.kmin) && IsFinite(out.dir_max) && IsFinite(out.dir_min);
  if (!out.valid) out = VertexEstimate{};
  return out;
}

}  // namespace

CurvatureField EstimateCurvature(const Mesh& mesh, const Topology& topology, const StopToken& stop) {
  const int32_t n = topology.num_vertices();
  CurvatureField f;
  f.normal.assign(n, Vec3{});
  f.dir_max.assign(n, Vec3{});
  f.dir_min.assign(n, Vec3{});
  f.kmax.assign(n, 0.0);
  f.kmin.assign(n, 0.0);
  f.valid.assign(n, 0);
  // Two passes (normals, then tensors from the finished normals); each vertex writes only its
  // own entries: the result does not depend on the thread count.
  std::atomic<bool> stopped{false};
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int32_t v = 0; v < n; ++v) {
    if (v % kStopPollInterval == 0 && stop.Fired()) stopped.store(true, std::memory_order_relaxed);
    if (stopped.load(std::memory_order_relaxed)) continue;
    f.normal[v] = VertexNormal(mesh, topology, v);
  }
  if (stopped.load()) return f;

#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int32_t v = 0; v < n; ++v) {
    if (v % kStopPollInterval == 0 && stop.Fired()) stopped.store(true, std::memory_order_relaxed);
    if (stopped.load(std::memory_order_relaxed)) continue;
    const VertexEstimate e = EstimateAt(mesh, topology, f.normal, v);
    if (!e.valid) continue;
    f.dir_max[v] = e.dir_max;
    f.dir_min[v] = e.dir_min;
    f.kmax[v] = e.kmax;
    f.kmin[v] = e.kmin;
    f.valid[v] = 1;
  }
  return f;
}

}  // namespace meshsmooth
