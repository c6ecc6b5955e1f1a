// Internal to core: merges points with exactly equal positions into one vertex, numbered in
// order of first appearance (STL's triangle soup; Draco points split at attribute seams).
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "core/mesh.h"
#include "core/vec3.h"

namespace meshsmooth {

struct Welded {
  std::vector<Vec3> positions;           // one per distinct position, in order of first appearance
  std::vector<int32_t> point_to_vertex;  // for each input point, its vertex
  int64_t merged = 0;                    // points merged into an earlier one
};

// +0.0 and -0.0 are the same position; a point with a NaN coordinate is never merged. Points
// are grouped by a radix sort of a per-process seeded hash (no hash map, which is much slower
// on large meshes), and exact equality is checked inside each group, so a hash collision merges
// nothing and crafted collisions cost O(k log k), not O(k^2). At most kMaxWeldPoints points:
// callers check their counts.
Welded WeldPoints(const std::vector<Vec3>& points);

// A mesh over points (a decoded Draco mesh's, or a mesh's own vertices) with its coincident
// points welded by WeldPoints: the welded vertices and the faces renumbered to them.
struct WeldedMesh {
  Mesh mesh;  // positions and triangles only
  // Per point, its vertex; empty when every point is its own vertex, in order (no coincident
  // points): 4 bytes a vertex fewer while a job runs.
  std::vector<int32_t> point_to_vertex;
  int64_t merged = 0;  // points merged into an earlier one
  int32_t VertexOf(size_t p) const { return point_to_vertex.empty() ? static_cast<int32_t>(p) : point_to_vertex[p]; }
};

// Welds `points` (WeldPoints) and renumbers `point_faces` (faces over point indices, every one
// in range) to the vertices.
WeldedMesh WeldMesh(const std::vector<Vec3>& points, std::vector<Triangle> point_faces);

// As WeldMesh, without a second copy of the faces where none is needed: when no point is
// merged, the faces are the welded mesh's as they are and are moved into it (`point_faces` is
// left empty: the caller takes them back from the result's mesh once done with it); otherwise
// `point_faces` stays as it was and the result holds them renumbered.
WeldedMesh WeldMeshLending(const std::vector<Vec3>& points, std::vector<Triangle>& point_faces);

// One value per vertex of `weld` from one per point: a vertex whose points disagree takes the
// smallest, and NaN when one of them is NaN (so that a check of the values finds it).
std::vector<float> VertexMinimum(const std::vector<float>& per_point, const WeldedMesh& weld, int64_t vertices);

// The position each vertex had before it moved: its first point's (WeldPoints numbers the
// vertices in the order their first points appear and gives each that point's position).
std::vector<Vec3> FirstPointPositions(const std::vector<Vec3>& points, const WeldedMesh& weld, int64_t vertices);

// The most points WeldPoints takes, 2^31 - 1: an index must fit the 31 bits packed beside the
// hash, and int32.
inline constexpr int64_t kMaxWeldPoints = std::numeric_limits<int32_t>::max();

}  // namespace meshsmooth
