#include "core/features/curvature.h"

#include <atomic>
#include <cmath>
#include <initializer_list>

namespace meshsmooth {
namespace {

// Below these relative sizes a normal, an edge or a tangent is numerically zero: the
// vertex (normal) or the neighbour (edge, tangent) is left out rather than divided by ~0.
constexpr double kTinyNormal = 1e-12;   // |sum of face cross products| vs sum of |edge|^2
constexpr double kTinyEdge = 1e-24;     // |edge|^2 vs sum of |edge|^2
constexpr double kTinyTangent = 1e-12;  // |tangent part|^2 vs |edge|^2
// The least-squares fit's normal equations (weights summing to 1, unit directions: the
// matrix has trace in [1, 1.5]) count as singular below this determinant: fewer than three
// distinct directions modulo pi (the fit is then undetermined), or nearly so.
constexpr double kTinyDeterminant = 1e-10;

// Below this many vertices the OpenMP team costs more than the loop.
constexpr int32_t kParallelMin = 4096;

struct VertexEstimate {
  Vec3 normal, dir_max, dir_min;
  double kmax = 0.0, kmin = 0.0;
  bool valid = false;
};

VertexEstimate EstimateAt(const Mesh& mesh, const Topology& topo, int32_t v) {
  VertexEstimate out;
  const VertexKind kind = topo.kind[v];
  if (kind != VertexKind::kInterior && kind != VertexKind::kBoundary) return out;
  const int32_t* ring = topo.ring.data() + topo.ring_offsets[v];
  const int32_t n = topo.valence(v);
  const Vec3 p = mesh.positions[v];
  if (!IsFinite(p)) return out;
  double sum_len2 = 0.0;
  for (int32_t k = 0; k < n; ++k) {
    const Vec3& q = mesh.positions[ring[k]];
    if (!IsFinite(q)) return out;
    sum_len2 += SquaredNorm(q - p);
  }
  // Face k is (P, Q_k, Q_k+1): cyclic for an interior vertex, an open fan on the boundary.
  const bool closed = kind == VertexKind::kInterior;
  const int32_t faces = closed ? n : n - 1;
  Vec3 normal_sum;
  for (int32_t k = 0; k < faces; ++k) {
    normal_sum += Cross(mesh.positions[ring[k]] - p, mesh.positions[ring[(k + 1) % n]] - p);
  }
  if (!(Norm(normal_sum) > kTinyNormal * sum_len2)) return out;
  const Vec3 normal = Normalized(normal_sum);
  if (!IsFinite(normal)) return out;  // overflow in the cross products of huge coordinates
  out.normal = normal;
  if (!closed || n < 3) return out;

  // Householder reflection Q = I - 2 W W^T with Q e1 = +-N (sign chosen against
  // cancellation); its second and third columns span the tangent plane.
  const Vec3 e1{1.0, 0.0, 0.0};
  const Vec3 minus = e1 - normal, plus = e1 + normal;
  const Vec3 w = Normalized(SquaredNorm(minus) > SquaredNorm(plus) ? minus : plus);
  const Vec3 t1 = Vec3{0.0, 1.0, 0.0} - w * (2.0 * w.y);
  const Vec3 t2 = Vec3{0.0, 0.0, 1.0} - w * (2.0 * w.z);

  // Weighted least squares for the tangent-plane tensor B = (b11 b12; b12 b22) in the basis
  // (t1, t2): minimise sum_j w_j (T_j^T B T_j - kappa_j)^2 with T_j = (a, b), i.e.
  // T_j^T B T_j = x_j . (b11, b12, b22) with x_j = (a^2, 2ab, b^2). Normal equations
  // G beta = h with G = sum w x x^T (symmetric 3x3, upper triangle g..), h = sum w kappa x.
  double g11 = 0.0, g12 = 0.0, g13 = 0.0, g22 = 0.0, g23 = 0.0, g33 = 0.0;
  double h1 = 0.0, h2 = 0.0, h3 = 0.0, weight_sum = 0.0;
  int32_t used = 0;
  double area_prev = Norm(Cross(mesh.positions[ring[n - 1]] - p, mesh.positions[ring[0]] - p));
  for (int32_t k = 0; k < n; ++k) {
    const Vec3 e = mesh.positions[ring[k]] - p;
    const double area_next = Norm(Cross(e, mesh.positions[ring[(k + 1) % n]] - p));
    const double weight = area_prev + area_next;  // the two faces at edge P Q_k
    area_prev = area_next;
    const double len2 = SquaredNorm(e);
    if (!(len2 > kTinyEdge * sum_len2)) continue;
    const Vec3 tangent = e - normal * Dot(normal, e);
    const double tan2 = SquaredNorm(tangent);
    if (!(tan2 > kTinyTangent * len2)) continue;
    const double kappa = -2.0 * Dot(normal, e) / len2;  // > 0 where the surface bends away from N
    const double inv_tan = 1.0 / std::sqrt(tan2);
    const double a = Dot(tangent, t1) * inv_tan, b = Dot(tangent, t2) * inv_tan;
    const double x1 = a * a, x2 = 2.0 * a * b, x3 = b * b;
    g11 += weight * x1 * x1;
    g12 += weight * x1 * x2;
    g13 += weight * x1 * x3;
    g22 += weight * x2 * x2;
    g23 += weight * x2 * x3;
    g33 += weight * x3 * x3;
    h1 += weight * kappa * x1;
    h2 += weight * kappa * x2;
    h3 += weight * kappa * x3;
    weight_sum += weight;
    ++used;
  }
  if (used < 3 || !(weight_sum > 0.0)) return out;
  const double inv_w = 1.0 / weight_sum;
  for (double* x : {&g11, &g12, &g13, &g22, &g23, &g33, &h1, &h2, &h3}) *x *= inv_w;

  // Cramer's rule through the cofactors of the symmetric G.
  const double c11 = g22 * g33 - g23 * g23, c12 = g13 * g23 - g12 * g33, c13 = g12 * g23 - g13 * g22;
  const double c22 = g11 * g33 - g13 * g13, c23 = g12 * g13 - g11 * g23, c33 = g11 * g22 - g12 * g12;
  const double det = g11 * c11 + g12 * c12 + g13 * c13;
  if (!(det > kTinyDeterminant)) return out;  // G is positive semi-definite: det >= 0 up to rounding
  const double inv_det = 1.0 / det;
  const double b11 = (c11 * h1 + c12 * h2 + c13 * h3) * inv_det;
  const double b12 = (c12 * h1 + c22 * h2 + c23 * h3) * inv_det;
  const double b22 = (c13 * h1 + c23 * h2 + c33 * h3) * inv_det;

  // Symmetric 2x2 eigen-decomposition of B: kmax = mean + radius along angle theta from t1.
  const double mean = 0.5 * (b11 + b22), radius = std::hypot(0.5 * (b11 - b22), b12);
  const double theta = 0.5 * std::atan2(2.0 * b12, b11 - b22);
  out.kmax = mean + radius;
  out.kmin = mean - radius;
  out.dir_max = t1 * std::cos(theta) + t2 * std::sin(theta);
  out.dir_min = Cross(normal, out.dir_max);
  out.valid = std::isfinite(out.kmax) && std::isfinite(out.kmin) && IsFinite(out.dir_max) &&
              IsFinite(out.dir_min);
  if (!out.valid) out = VertexEstimate{normal, {}, {}, 0.0, 0.0, false};
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
  // Each vertex writes only its own entries: the result does not depend on the thread count.
  std::atomic<bool> stopped{false};
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int32_t v = 0; v < n; ++v) {
    if (v % kStopPollInterval == 0 && stop.Fired()) stopped.store(true, std::memory_order_relaxed);
    if (stopped.load(std::memory_order_relaxed)) continue;
    const VertexEstimate e = EstimateAt(mesh, topology, v);
    f.normal[v] = e.normal;
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
