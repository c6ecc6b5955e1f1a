// Shape and mesh-quality numbers shared by the tests, the benchmarks and the job summary.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "absl/status/statusor.h"
#include "core/mesh.h"
#include "core/topology.h"
#include "core/util/stop_token.h"

namespace meshsmooth {

struct MeshMetrics {
  double area = 0.0;           // sum of the usable faces' areas
  double signed_volume = 0.0;  // sum of det(a-c, b-c, ...)/6 about the centroid c; > 0 outward
  double edge_length_mean = 0.0;
  double edge_length_cv = 0.0;            // standard deviation / mean over the unique edges
  double min_angle_deg = 0.0;             // smallest triangle angle
  double mean_angle_deg = 0.0;            // mean of the smallest angle of each face
  double share_angles_below_10deg = 0.0;  // of all triangle angles
};

// Metrics of the usable faces and edges of `topo` (built from `mesh`). Once `stop` fires, the
// blocks of faces and edges left are skipped: a caller that passes a token checks it after.
MeshMetrics ComputeMetrics(const Mesh& mesh, const Topology& topo, const StopToken& stop = {});

// ComputeMetrics() while `beside` runs on one thread of the same team of max(2, threads)
// threads (0 = hardware threads): the others start on the metrics' blocks, and the thread that
// ran `beside` takes blocks too once it returns (a job encodes beside them). The same bits as
// ComputeMetrics(): the blocks are merged in the same order. Below kMetricsTeamMinVertices
// vertices `beside` and then the metrics run on the calling thread: no
// team is started (its threads would spin-wait after the job, beside the client's decode and
// write on a small machine).
inline constexpr int32_t kMetricsTeamMinVertices = 20000;
MeshMetrics ComputeMetricsBeside(const Mesh& mesh, const Topology& topo, const std::function<void()>& beside,
                                 int threads = 0, const StopToken& stop = {});

// A vertex is at a bound on displacement (FlowParams::max_displacement) when it moved at least
// (1 - kAtBoundTolerance) times the bound: a run puts the vertices it holds at the bound exactly,
// and a float32 coordinate's rounding moves them by far less than this share of any bound above
// a ten-thousandth of the coordinates' magnitude.
inline constexpr double kAtBoundTolerance = 1e-3;

// Whether triangle `t`'s normal turned by more than 90 degrees from positions `before` to
// `after`: Displacement::flipped_normals counts the usable faces where it did, and an enhancement
// holds its vertices back until none did (core/job/enhance.h). A face of zero area at either
// positions has not turned.
inline bool NormalFlipped(const Triangle& t, const Vec3* before, const Vec3* after) {
  const Vec3 a = Cross(before[t[1]] - before[t[0]], before[t[2]] - before[t[0]]);
  const Vec3 b = Cross(after[t[1]] - after[t[0]], after[t[2]] - after[t[0]]);
  return Dot(a, b) < 0.0;
}

struct Displacement {
  double rms = 0.0;  // RMS of |after_i - before_i| over all vertices
  double max = 0.0;
  int64_t flipped_normals = 0;  // usable faces whose normal turned by more than 90 degrees
  // With a bound: the vertices at it (kAtBoundTolerance), each displacement measured from
  // `after` rounded to float32 as a lossless result holds it; 0 without a bound.
  int64_t at_bound = 0;
};

// Compares two meshes with the same connectivity. InvalidArgument when the vertex counts or
// triangles differ.
absl::StatusOr<Displacement> CompareMeshes(const Mesh& before, const Mesh& after);

// Same, for `after` and the positions its vertices had before (its triangles throughout): a
// job keeps only the input's positions, not a second copy of the triangles; with `bound` > 0
// (mesh units), Displacement::at_bound counts the vertices at it. InvalidArgument when the
// vertex counts differ.
absl::StatusOr<Displacement> CompareMeshes(const std::vector<Vec3>& before, const Mesh& after, double bound = 0.0);

// Mean edge length of the usable faces' unique edges (0 for a mesh without edges).
double MeanEdgeLength(const Mesh& mesh, const Topology& topo);

std::string FormatMetrics(const MeshMetrics& m);

}  // namespace meshsmooth
