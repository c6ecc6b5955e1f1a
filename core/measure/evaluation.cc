#include "core/measure/evaluation.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/measure/metrics.h"

namespace meshsmooth {
namespace {

enum FaceClass : uint8_t { kSkipped, kPlain, kCrease };

// Vertices per block of the distance pass; blocks are summed in order, so the figures do not
// depend on the number of threads.
constexpr int32_t kDistanceBlock = 4096;

double AngleDeg(const Vec3& a, const Vec3& b) {
  // atan2 rather than acos of the normalised dot: exact 0 for parallel normals, and accurate
  // for the small angles that matter here.
  return std::atan2(Norm(Cross(a, b)), Dot(a, b)) * (180.0 / std::numbers::pi);
}

Vec3 FaceCross(const std::vector<Vec3>& positions, const Triangle& t) {
  const Vec3& a = positions[t[0]];
  return Cross(positions[t[1]] - a, positions[t[2]] - a);
}

struct DistanceSums {
  double sum2 = 0.0, max2 = 0.0;
  int64_t count = 0, non_finite = 0;
};

}  // namespace

GroundTruth::GroundTruth(Mesh clean, double crease_angle_deg)
    : mesh_(std::move(clean)), topo_(BuildTopology(mesh_, &report_)), surface_(mesh_) {
  h_ = MeanEdgeLength(mesh_, topo_);
  volume_ = ComputeMetrics(mesh_, topo_).signed_volume;
  BoundingBox box;
  for (const Vec3& p : mesh_.positions) box.Add(p);
  // The validation report's zero-area faces: area < 1e-12 diagonal^2, |cross| = 2 area.
  zero_cross_ = 2e-12 * box.diagonal() * box.diagonal();

  const auto faces = static_cast<int32_t>(topo_.faces.size());
  face_cross_.resize(faces);
  face_class_.assign(faces, kSkipped);
  for (int32_t f = 0; f < faces; ++f) {
    face_cross_[f] = FaceCross(mesh_.positions, mesh_.triangles[topo_.faces[f]]);
    if (Norm(face_cross_[f]) >= zero_cross_) face_class_[f] = kPlain;
  }

  // The faces around each vertex (CSR), to find the other face of each edge.
  const int32_t n = mesh_.num_vertices();
  std::vector<int32_t> offsets(n + 1, 0), around(3 * static_cast<size_t>(faces));
  for (int32_t f = 0; f < faces; ++f) {
    for (int32_t v : mesh_.triangles[topo_.faces[f]]) ++offsets[v + 1];
  }
  for (int32_t v = 0; v < n; ++v) offsets[v + 1] += offsets[v];
  std::vector<int32_t> fill(offsets.begin(), offsets.end() - 1);
  for (int32_t f = 0; f < faces; ++f) {
    for (int32_t v : mesh_.triangles[topo_.faces[f]]) around[fill[v]++] = f;
  }
  const double crease = crease_angle_deg;
  std::vector<uint8_t> is_crease(faces, 0);
  folded_.assign(faces, 0);
  for (int32_t f = 0; f < faces; ++f) {
    if (face_class_[f] == kSkipped) continue;
    const Triangle& t = mesh_.triangles[topo_.faces[f]];
    for (int k = 0; k < 3 && !folded_[f]; ++k) {
      const int32_t a = t[k], b = t[(k + 1) % 3];
      // The edge's other faces: those around a that also hold b. A dihedral angle is defined
      // for an edge with exactly two faces, both with a normal.
      int32_t other = -1, count = 0;
      for (int32_t i = offsets[a]; i < offsets[a + 1]; ++i) {
        const int32_t g = around[i];
        if (g == f) continue;
        const Triangle& u = mesh_.triangles[topo_.faces[g]];
        if (u[0] == b || u[1] == b || u[2] == b) {
          other = g;
          ++count;
        }
      }
      if (count == 1 && face_class_[other] != kSkipped) {
        const double angle = AngleDeg(face_cross_[f], face_cross_[other]);
        is_crease[f] |= angle > crease;
        folded_[f] = angle > 90.0;
      }
    }
  }
  // Fine detail: the clean area-weighted vertex normals (sums of the measured faces' cross
  // products) at two corners of the face more than kFineDetailTurnDeg apart.
  std::vector<Vec3> vertex_normal(n);
  for (int32_t f = 0; f < faces; ++f) {
    if (face_class_[f] == kSkipped) continue;
    for (int32_t v : mesh_.triangles[topo_.faces[f]]) vertex_normal[v] += face_cross_[f];
  }
  fine_.assign(faces, 0);
  for (int32_t f = 0; f < faces; ++f) {
    if (face_class_[f] == kSkipped) continue;
    const Triangle& t = mesh_.triangles[topo_.faces[f]];
    for (int k = 0; k < 3; ++k) {
      const Vec3& a = vertex_normal[t[k]];
      const Vec3& b = vertex_normal[t[(k + 1) % 3]];
      if (AngleDeg(a, b) > kFineDetailTurnDeg) fine_[f] = 1;
    }
  }
  for (int32_t f = 0; f < faces; ++f) {
    if (face_class_[f] == kSkipped) continue;
    ++measured_faces_;
    folded_faces_ += folded_[f];
    fine_detail_faces_ += fine_[f];
    if (is_crease[f]) {
      face_class_[f] = kCrease;
      ++crease_faces_;
    }
  }
}

absl::StatusOr<Quality> GroundTruth::Evaluate(const Mesh& result) const {
  if (result.num_vertices() != mesh_.num_vertices()) {
    return absl::InvalidArgumentError(
        absl::StrCat("vertex counts differ: ", mesh_.num_vertices(), " clean, ", result.num_vertices(), " result"));
  }
  if (result.triangles != mesh_.triangles) return absl::InvalidArgumentError("the meshes' triangles differ");
  Quality q;

  // Distances: the clean position of a vertex lies on the clean surface, so its distance to
  // the result's vertex bounds the search from the start.
  const int32_t n = mesh_.num_vertices();
  const int32_t blocks = (n + kDistanceBlock - 1) / kDistanceBlock;
  std::vector<DistanceSums> parts(blocks);
#pragma omp parallel for schedule(dynamic, 1)
  for (int32_t b = 0; b < blocks; ++b) {
    DistanceSums s;
    for (int32_t v = b * kDistanceBlock; v < std::min(n, (b + 1) * kDistanceBlock); ++v) {
      if (topo_.kind[v] == VertexKind::kIsolated) continue;
      const Vec3& p = result.positions[v];
      if (!IsFinite(p)) {
        ++s.non_finite;
        continue;
      }
      const double d2 = surface_.SquaredDistance(p, SquaredNorm(p - mesh_.positions[v]));
      s.sum2 += d2;
      s.max2 = std::max(s.max2, d2);
      ++s.count;
    }
    parts[b] = s;
  }
  DistanceSums total;
  for (const DistanceSums& s : parts) {
    total.sum2 += s.sum2;
    total.max2 = std::max(total.max2, s.max2);
    total.count += s.count;
    total.non_finite += s.non_finite;
  }
  q.non_finite_vertices = total.non_finite;
  if (total.non_finite > 0) {
    q.rms_distance = q.max_distance = std::nan("");
  } else if (total.count > 0 && h_ > 0.0) {
    q.rms_distance = std::sqrt(total.sum2 / static_cast<double>(total.count)) / h_;
    q.max_distance = std::sqrt(total.max2) / h_;
  }

  // Normals: faces with a normal in both meshes.
  double sum = 0.0, crease_sum = 0.0;
  int64_t count = 0, crease_count = 0, flipped = 0, flipped_fine = 0;
  for (size_t f = 0; f < topo_.faces.size(); ++f) {
    if (face_class_[f] == kSkipped) continue;
    const Vec3 r = FaceCross(result.positions, result.triangles[topo_.faces[f]]);
    if (!(Norm(r) >= zero_cross_)) continue;
    const double angle = AngleDeg(face_cross_[f], r);
    const bool flip = !folded_[f] && Dot(face_cross_[f], r) < 0.0;
    flipped += flip;
    flipped_fine += flip && fine_[f];
    sum += angle;
    ++count;
    if (face_class_[f] == kCrease) {
      crease_sum += angle;
      ++crease_count;
    }
  }
  q.normal_error_deg = count > 0 ? sum / static_cast<double>(count) : std::nan("");
  q.crease_normal_error_deg = crease_count > 0 ? crease_sum / static_cast<double>(crease_count) : std::nan("");

  const MeshMetrics m = ComputeMetrics(result, topo_);
  q.volume_change_percent = closed() && volume_ != 0.0 ? 100.0 * (m.signed_volume / volume_ - 1.0) : std::nan("");
  q.edge_length_cv = m.edge_length_cv;
  q.min_angle_deg = m.min_angle_deg;
  q.flipped_faces = flipped;
  q.flipped_in_fine_detail = flipped_fine;
  return q;
}

}  // namespace meshsmooth
