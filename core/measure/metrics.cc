#include "core/measure/metrics.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"

namespace meshsmooth {
namespace {

// Fixed blocks of this many items, reduced in block order: sums do not depend on threads.
constexpr int64_t kMetricBlock = 16384;
// Blocks go to at most this many tasks inside ComputeMetricsBeside.
constexpr int64_t kMetricTasks = 32;

// fn(begin, end) -> Partial for each block of [0, n), on all cores when n is large; the
// partials are merged in block order. Inside a team (ComputeMetricsBeside) the blocks are
// tasks, taken by whichever of its threads is free. Once `stop` fires, the blocks left count
// as empty.
template <typename Partial, typename Fn, typename Merge>
Partial BlockReduce(int64_t n, const StopToken& stop, Fn&& fn, Merge&& merge) {
  const int64_t blocks = (n + kMetricBlock - 1) / kMetricBlock;
  std::vector<Partial> parts(static_cast<size_t>(blocks));
  auto block = [&](int64_t b) {
    if (!stop.Fired()) parts[b] = fn(b * kMetricBlock, std::min(n, (b + 1) * kMetricBlock));
  };
  if (omp_in_parallel()) {
    // At most kMetricTasks tasks: libgomp runs tasks beyond 64 per thread at once on the thread
    // that makes them, which then leaves nothing for a thread that comes free.
#pragma omp taskloop num_tasks(std::min <int64_t>(blocks, kMetricTasks)) default(shared)
    for (int64_t b = 0; b < blocks; ++b) block(b);
  } else {
#pragma omp parallel for schedule(static) if (blocks > 4)
    for (int64_t b = 0; b < blocks; ++b) block(b);
  }
  Partial total{};
  for (const Partial& p : parts) merge(total, p);
  return total;
}

struct EdgeLengthSums {
  double sum = 0.0, sum_sq = 0.0;  // of the lengths and of their squares
  int64_t count = 0;
};

// Rings are contiguous but the positions they name are scattered in a mesh's own order: the
// edge pass prefetches the position of the ring entry this far ahead (it pays on meshes too
// large for the caches; docs/decisions.md, "Speed").
constexpr int32_t kEdgePrefetchEntries = 64;

// The lengths of the edges (a < b) of the vertices' rings, summed in fixed blocks of vertices:
// one pass serves the mean and the spread.
EdgeLengthSums SumEdgeLengths(const Mesh& mesh, const Topology& topo, const StopToken& stop = {}) {
  return BlockReduce<EdgeLengthSums>(
      topo.num_vertices(), stop,
      [&](int64_t begin, int64_t end) {
        EdgeLengthSums p;
        const int32_t ring_end = topo.ring_offsets[end];
        for (int32_t v = static_cast<int32_t>(begin); v < end; ++v) {
          for (int32_t i = topo.ring_offsets[v]; i < topo.ring_offsets[v + 1]; ++i) {
            const int32_t ahead = i + kEdgePrefetchEntries;
            if (ahead < ring_end) __builtin_prefetch(&mesh.positions[topo.ring[ahead]]);
            if (v < topo.ring[i]) {
              const double len = Norm(mesh.positions[v] - mesh.positions[topo.ring[i]]);
              p.sum += len;
              p.sum_sq += len * len;
              ++p.count;
            }
          }
        }
        return p;
      },
      [](EdgeLengthSums& t, const EdgeLengthSums& p) {
        t.sum += p.sum;
        t.sum_sq += p.sum_sq;
        t.count += p.count;
      });
}

double MeanOf(const EdgeLengthSums& e) { return e.count > 0 ? e.sum / static_cast<double>(e.count) : 0.0; }

}  // namespace

double MeanEdgeLength(const Mesh& mesh, const Topology& topo) { return MeanOf(SumEdgeLengths(mesh, topo)); }

MeshMetrics ComputeMetrics(const Mesh& mesh, const Topology& topo, const StopToken& stop) {
  MeshMetrics m;
  Vec3 centroid;
  int64_t referenced = 0;
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kIsolated) continue;
    centroid += mesh.positions[v];
    ++referenced;
  }
  if (referenced > 0) centroid *= 1.0 / static_cast<double>(referenced);

  struct FacePartial {
    double area = 0.0, volume = 0.0, min_angle = std::numeric_limits<double>::infinity(), sum_min_angle = 0.0;
    int64_t below10 = 0;
  };
  const double tan10 = std::tan(10.0 * std::numbers::pi / 180.0);
  const FacePartial faces = BlockReduce<FacePartial>(
      static_cast<int64_t>(topo.faces.size()), stop,
      [&](int64_t begin, int64_t end) {
        FacePartial q;
        for (int64_t i = begin; i < end; ++i) {
          const Triangle& t = mesh.triangles[topo.faces[i]];
          const Vec3 a = mesh.positions[t[0]] - centroid, b = mesh.positions[t[1]] - centroid,
                     c = mesh.positions[t[2]] - centroid;
          const Vec3 ab = b - a, bc = c - b, ca = a - c;
          const double cross = Norm(Cross(ab, -ca));  // twice the area, shared by the three angles
          q.area += 0.5 * cross;
          q.volume += Dot(a, Cross(b, c)) / 6.0;
          // Angle at a corner = atan2(cross, dot of its two edges); below 10 degrees exactly when
          // the dot is positive and cross < tan(10 deg) dot (or the corner is degenerate).
          const double dots[3] = {-Dot(ab, ca), -Dot(bc, ab), -Dot(ca, bc)};  // at a, b, c
          for (double d : dots) q.below10 += (d > 0.0 && cross < tan10 * d) || (d == 0.0 && cross == 0.0);
          // The smallest angle is opposite the shortest edge: one arctangent per face.
          const double lab = SquaredNorm(ab), lbc = SquaredNorm(bc), lca = SquaredNorm(ca);
          const double d = lbc <= lab && lbc <= lca ? dots[0] : (lca <= lab ? dots[1] : dots[2]);
          // The smallest angle is at most 60 degrees, so d > 0 but for degenerate corners, where
          // atan(cross / d) is atan2's value (to an ulp) and cheaper. atan2 keeps the degenerate
          // cases (d = 0 with cross = 0 gives 0, not NaN).
          const double face_min = d > 0.0 ? std::atan(cross / d) : std::atan2(cross, d);
          q.min_angle = std::min(q.min_angle, face_min);
          q.sum_min_angle += face_min;
        }
        return q;
      },
      [](FacePartial& t, const FacePartial& q) {
        t.area += q.area;
        t.volume += q.volume;
        t.min_angle = std::min(t.min_angle, q.min_angle);
        t.sum_min_angle += q.sum_min_angle;
        t.below10 += q.below10;
      });
  m.area = faces.area;
  m.signed_volume = faces.volume;
  const double min_angle = faces.min_angle, sum_min_angle = faces.sum_min_angle;
  const int64_t below10 = faces.below10;
  const double nf = static_cast<double>(topo.faces.size());
  if (!topo.faces.empty()) {
    m.min_angle_deg = min_angle * 180.0 / std::numbers::pi;
    m.mean_angle_deg = sum_min_angle / nf * 180.0 / std::numbers::pi;
    m.share_angles_below_10deg = static_cast<double>(below10) / (3.0 * nf);
  }

  // One pass over the edges: the variance as E[l^2] - E[l]^2 (edge lengths of one mesh have a
  // CV well above the 1e-8 where that would lose digits), without a second pass over the edges
  // for the deviations from the mean.
  const EdgeLengthSums edges = SumEdgeLengths(mesh, topo, stop);
  m.edge_length_mean = MeanOf(edges);
  if (edges.count > 0 && m.edge_length_mean > 0.0) {
    const double mean_sq = edges.sum_sq / static_cast<double>(edges.count);
    const double variance = std::max(0.0, mean_sq - m.edge_length_mean * m.edge_length_mean);
    m.edge_length_cv = std::sqrt(variance) / m.edge_length_mean;
  }
  return m;
}

MeshMetrics ComputeMetricsBeside(const Mesh& mesh, const Topology& topo, const std::function<void()>& beside,
                                 int threads, const StopToken& stop) {
  if (topo.num_vertices() < kMetricsTeamMinVertices) {
    beside();
    return ComputeMetrics(mesh, topo, stop);
  }
  MeshMetrics m;
  const int team = std::max(2, threads > 0 ? threads : omp_get_max_threads());
#pragma omp parallel num_threads(team)
#pragma omp single
  {
#pragma omp task default(shared)
    beside();
    m = ComputeMetrics(mesh, topo, stop);
  }
  return m;
}

absl::StatusOr<Displacement> CompareMeshes(const Mesh& before, const Mesh& after) {
  if (before.triangles != after.triangles) {
    return absl::InvalidArgumentError("the meshes' triangles differ");
  }
  return CompareMeshes(before.positions, after);
}

absl::StatusOr<Displacement> CompareMeshes(const std::vector<Vec3>& before, const Mesh& after, double bound) {
  if (before.size() != after.positions.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("vertex counts differ: ", before.size(), " and ", after.positions.size()));
  }
  Displacement d;
  double sq = 0.0;
  const double at_bound = (1.0 - kAtBoundTolerance) * bound;
  for (size_t i = 0; i < before.size(); ++i) {
    const double len = Norm(after.positions[i] - before[i]);
    sq += len * len;
    d.max = std::max(d.max, len);
    if (bound > 0.0) {
      const Vec3& p = after.positions[i];
      const Vec3 written{static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
      d.at_bound += Norm(written - before[i]) >= at_bound;
    }
  }
  if (!before.empty()) d.rms = std::sqrt(sq / static_cast<double>(before.size()));
  const int32_t n = after.num_vertices();
  for (const Triangle& t : after.triangles) {
    if (IsUsableTriangle(t, n) && NormalFlipped(t, before.data(), after.positions.data())) ++d.flipped_normals;
  }
  return d;
}

std::string FormatMetrics(const MeshMetrics& m) {
  std::ostringstream o;
  o << "area: " << m.area << "\n"
    << "signed volume: " << m.signed_volume << "\n"
    << "edge length mean: " << m.edge_length_mean << "\n"
    << "edge length CV: " << m.edge_length_cv << "\n"
    << "min angle (deg): " << m.min_angle_deg << "\n"
    << "mean of the faces' min angle (deg): " << m.mean_angle_deg << "\n"
    << "angles below 10 deg: " << 100.0 * m.share_angles_below_10deg << "%\n";
  return o.str();
}

}  // namespace meshsmooth
