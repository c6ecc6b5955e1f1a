// Internal to core: merges points with exactly equal positions into one vertex, numbered in
// order of first appearance (STL's triangle soup; Draco points split at attribute seams).
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

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

// The most points WeldPoints takes, 2^31 - 1: an index must fit the 31 bits packed beside the
// hash, and int32.
inline constexpr int64_t kMaxWeldPoints = std::numeric_limits<int32_t>::max();

}  // namespace meshsmooth
