#include "core/measure/surface_distance.h"

#include <algorithm>
#include <utility>

namespace meshsmooth {
namespace {

constexpr int32_t kLeafTriangles = 4;
// A median split halves every range, so no path is deeper than log2 of 2^31 triangles; the
// query's stack holds at most one node per level plus one.
constexpr int kMaxDepth = 64;

Vec3 ClosestPointOnSegment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = SquaredNorm(ab);
  if (!(len2 > 0.0)) return a;
  const double t = std::clamp(Dot(p - a, ab) / len2, 0.0, 1.0);
  return a + t * ab;
}

Vec3 ClosestPointOnEdges(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  Vec3 best = ClosestPointOnSegment(p, a, b);
  double best2 = SquaredNorm(p - best);
  for (const Vec3& q : {ClosestPointOnSegment(p, b, c), ClosestPointOnSegment(p, c, a)}) {
    const double d2 = SquaredNorm(p - q);
    if (d2 < best2) {
      best = q;
      best2 = d2;
    }
  }
  return best;
}

double BoxSquaredDistance(const BoundingBox& box, const Vec3& p) {
  const double dx = std::max({box.lo.x - p.x, 0.0, p.x - box.hi.x});
  const double dy = std::max({box.lo.y - p.y, 0.0, p.y - box.hi.y});
  const double dz = std::max({box.lo.z - p.z, 0.0, p.z - box.hi.z});
  return dx * dx + dy * dy + dz * dz;
}

double Axis(const Vec3& v, int axis) { return axis == 0 ? v.x : (axis == 1 ? v.y : v.z); }

}  // namespace

Vec3 ClosestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a;
  if (SquaredNorm(Cross(ab, ac)) == 0.0) return ClosestPointOnEdges(p, a, b, c);
  // d1..d6 place p against the corners along ab and ac; va, vb, vc are the unnormalised
  // barycentric coordinates of p's projection (each the triple product with the normal).
  const Vec3 ap = p - a;
  const double d1 = Dot(ab, ap), d2 = Dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Vec3 bp = p - b;
  const double d3 = Dot(ab, bp), d4 = Dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const double d5 = Dot(ab, cp), d6 = Dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double sum = va + vb + vc;
  // Rounding can leave a needle's sum at or below 0, where the interior formula means nothing.
  if (!(sum > 0.0)) return ClosestPointOnEdges(p, a, b, c);
  return a + (vb / sum) * ab + (vc / sum) * ac;
}

SurfaceDistance::SurfaceDistance(const Mesh& mesh) {
  const int32_t n = mesh.num_vertices();
  std::vector<std::array<Vec3, 3>> triangles;
  std::vector<int32_t> ids;
  triangles.reserve(mesh.triangles.size());
  for (int32_t f = 0; f < mesh.num_triangles(); ++f) {
    const Triangle& t = mesh.triangles[f];
    if (!IsUsableTriangle(t, n)) continue;
    const std::array<Vec3, 3> c = {mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]};
    if (IsFinite(c[0]) && IsFinite(c[1]) && IsFinite(c[2])) {
      triangles.push_back(c);
      ids.push_back(f);
    }
  }
  if (triangles.empty()) return;
  std::vector<Vec3> centroids(triangles.size());
  for (size_t i = 0; i < triangles.size(); ++i) {
    centroids[i] = (triangles[i][0] + triangles[i][1] + triangles[i][2]) * (1.0 / 3.0);
  }
  std::vector<int32_t> order(triangles.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int32_t>(i);

  struct Range {
    int32_t node, begin, end;
  };
  nodes_.reserve(2 * (triangles.size() / kLeafTriangles + 1));
  nodes_.emplace_back();
  std::vector<Range> work = {{0, 0, static_cast<int32_t>(order.size())}};
  while (!work.empty()) {
    const Range r = work.back();
    work.pop_back();
    BoundingBox box, centres;
    for (int32_t i = r.begin; i < r.end; ++i) {
      for (const Vec3& c : triangles[order[i]]) box.Add(c);
      centres.Add(centroids[order[i]]);
    }
    nodes_[r.node].box = box;
    const Vec3 extent = centres.hi - centres.lo;
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
    if (r.end - r.begin <= kLeafTriangles || Axis(extent, axis) == 0.0) {
      nodes_[r.node].first = r.begin;
      nodes_[r.node].count = r.end - r.begin;
      continue;
    }
    const int32_t mid = r.begin + (r.end - r.begin) / 2;
    std::nth_element(order.begin() + r.begin, order.begin() + mid, order.begin() + r.end,
                     [&](int32_t x, int32_t y) { return Axis(centroids[x], axis) < Axis(centroids[y], axis); });
    const auto left = static_cast<int32_t>(nodes_.size());
    nodes_.resize(nodes_.size() + 2);
    nodes_[r.node].first = left;
    nodes_[r.node].count = 0;
    work.push_back({left, r.begin, mid});
    work.push_back({left + 1, mid, r.end});
  }
  corners_.resize(order.size());
  ids_.resize(order.size());
  for (size_t i = 0; i < order.size(); ++i) {
    corners_[i] = triangles[order[i]];
    ids_[i] = ids[order[i]];
  }
}

template <typename Visit>
void SurfaceDistance::Search(const Vec3& p, double& best, Visit&& visit) const {
  if (nodes_.empty() || !(BoxSquaredDistance(nodes_[0].box, p) < best)) return;
  int32_t stack[kMaxDepth];
  int sp = 0;
  stack[sp++] = 0;
  while (sp > 0) {
    const Node& node = nodes_[stack[--sp]];
    if (!(BoxSquaredDistance(node.box, p) < best)) continue;  // best shrank since it was pushed
    if (node.count > 0) {
      for (int32_t i = node.first; i < node.first + node.count; ++i) visit(i);
      continue;
    }
    int32_t near = node.first, far = node.first + 1;
    double near2 = BoxSquaredDistance(nodes_[near].box, p), far2 = BoxSquaredDistance(nodes_[far].box, p);
    if (far2 < near2) {
      std::swap(near, far);
      std::swap(near2, far2);
    }
    // The nearer child goes on top, so it is searched first and its best prunes the other.
    if (far2 < best) stack[sp++] = far;
    if (near2 < best) stack[sp++] = near;
  }
}

double SurfaceDistance::SquaredDistance(const Vec3& p, double bound2) const {
  if (!IsFinite(p)) return std::nan("");
  double best = bound2;
  Search(p, best, [&](int32_t i) {
    const std::array<Vec3, 3>& t = corners_[i];
    best = std::min(best, SquaredNorm(p - ClosestPointOnTriangle(p, t[0], t[1], t[2])));
  });
  return best;
}

int32_t SurfaceDistance::NearestTriangle(const Vec3& p, double* squared_distance) const {
  double best = HUGE_VAL;
  int32_t nearest = -1;
  if (IsFinite(p)) {
    Search(p, best, [&](int32_t i) {
      const std::array<Vec3, 3>& t = corners_[i];
      const double d2 = SquaredNorm(p - ClosestPointOnTriangle(p, t[0], t[1], t[2]));
      if (d2 < best) {
        best = d2;
        nearest = ids_[i];
      }
    });
  }
  if (squared_distance != nullptr) *squared_distance = nearest >= 0 ? best : std::nan("");
  return nearest;
}

}  // namespace meshsmooth
