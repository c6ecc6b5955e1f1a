#include "core/weld.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <utility>

#include "absl/hash/hash.h"
#include "core/util/radix_sort.h"

namespace meshsmooth {
namespace {

// Bit patterns of the coordinates with -0.0 turned into +0.0 (x + 0.0 does that).
std::array<uint64_t, 3> Bits(const Vec3& p) {
  const double c[3] = {p.x + 0.0, p.y + 0.0, p.z + 0.0};
  std::array<uint64_t, 3> b;
  std::memcpy(b.data(), c, sizeof c);
  return b;
}

bool HasNan(const Vec3& p) { return std::isnan(p.x) || std::isnan(p.y) || std::isnan(p.z); }

}  // namespace

Welded WeldPoints(const std::vector<Vec3>& points) {
  const size_t n = points.size();
  Welded w;
  w.point_to_vertex.resize(n);
  w.positions.reserve(n);
  // (hash, index) packed as the hash's low 33 bits above a 31-bit index (point_to_vertex is
  // int32) and sorted by the hash bits, stably (RadixSortBits): equal positions end up adjacent
  // with their indices ascending, and other positions share a key rarely (~n^2 / 2^34 pairs).
  // Three passes of 11 bits (2048 buckets) rather than the whole hash in four 16-bit ones, whose
  // scattered writes miss the caches (docs/decisions.md, "Speed").
  constexpr int kIndexBits = 31, kDigitBits = 11, kPasses = 3;
  constexpr uint64_t kIndexMask = (uint64_t{1} << kIndexBits) - 1;
  std::vector<uint64_t> key(n);
  const absl::Hash<std::array<uint64_t, 3>> hash;
  for (size_t i = 0; i < n; ++i) key[i] = hash(Bits(points[i])) << kIndexBits | i;
  RadixSortBits(key, kIndexBits, kDigitBits, kPasses, 1);
  constexpr uint64_t kSortedBits = ((uint64_t{1} << (kDigitBits * kPasses)) - 1) << kIndexBits;
  std::vector<uint32_t> idx(n), rep(n);
  for (size_t i = 0; i < n; ++i) {
    idx[i] = static_cast<uint32_t>(key[i] & kIndexMask);
    key[i] &= kSortedBits;
  }

  // rep[p]: the first point with exactly p's position. Inside a run of equal keys, sort by the
  // bit patterns (then index) and take the first of each group of equal positions.
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && key[j] == key[i]) ++j;
    if (j - i == 1) {
      rep[idx[i]] = idx[i];
    } else {
      std::sort(idx.begin() + static_cast<std::ptrdiff_t>(i), idx.begin() + static_cast<std::ptrdiff_t>(j),
                [&](uint32_t a, uint32_t b) {
                  const auto ka = Bits(points[a]), kb = Bits(points[b]);
                  return ka != kb ? ka < kb : a < b;
                });
      uint32_t first = idx[i];
      for (size_t k = i; k < j; ++k) {
        const uint32_t p = idx[k];
        if (k > i && (HasNan(points[p]) || Bits(points[p]) != Bits(points[first]))) first = p;
        rep[p] = HasNan(points[p]) ? p : first;
      }
    }
    i = j;
  }

  int32_t next = 0;
  for (size_t p = 0; p < n; ++p) {
    if (rep[p] == p) {
      w.point_to_vertex[p] = next++;
      w.positions.push_back(points[p]);
    } else {
      w.point_to_vertex[p] = w.point_to_vertex[rep[p]];
      ++w.merged;
    }
  }
  return w;
}

namespace {

// True when every point is its own vertex, in order (the vertices are numbered in order of first
// appearance, so with no point merged).
bool IsIdentity(const Welded& w) {
  bool identity = w.merged == 0;
  for (size_t p = 0; identity && p < w.point_to_vertex.size(); ++p) {
    identity = w.point_to_vertex[p] == static_cast<int32_t>(p);
  }
  return identity;
}

// The welded mesh of `w` over `point_faces`, renumbered in place unless `w` is the identity.
WeldedMesh FromWelded(Welded w, std::vector<Triangle> point_faces) {
  WeldedMesh out;
  out.mesh.positions = std::move(w.positions);
  out.merged = w.merged;
  out.mesh.triangles = std::move(point_faces);
  if (IsIdentity(w)) return out;
  for (Triangle& t : out.mesh.triangles) {
    for (int32_t& v : t) v = w.point_to_vertex[v];
  }
  out.point_to_vertex = std::move(w.point_to_vertex);
  return out;
}

}  // namespace

WeldedMesh WeldMesh(const std::vector<Vec3>& points, std::vector<Triangle> point_faces) {
  return FromWelded(WeldPoints(points), std::move(point_faces));
}

WeldedMesh WeldMeshLending(const std::vector<Vec3>& points, std::vector<Triangle>& point_faces) {
  Welded w = WeldPoints(points);
  if (!IsIdentity(w)) return FromWelded(std::move(w), point_faces);
  WeldedMesh out = FromWelded(std::move(w), std::move(point_faces));
  point_faces.clear();
  return out;
}

std::vector<float> VertexMinimum(const std::vector<float>& per_point, const WeldedMesh& weld, int64_t vertices) {
  std::vector<float> values(vertices, std::numeric_limits<float>::infinity());
  std::vector<uint8_t> seen(vertices, 0);
  for (size_t p = 0; p < per_point.size(); ++p) {
    const float value = per_point[p];
    float& v = values[weld.VertexOf(p)];
    uint8_t& first = seen[weld.VertexOf(p)];
    v = !first || std::isnan(value) ? value : std::isnan(v) ? v : std::min(v, value);
    first = 1;
  }
  return values;
}

std::vector<Vec3> FirstPointPositions(const std::vector<Vec3>& points, const WeldedMesh& weld, int64_t vertices) {
  std::vector<Vec3> positions;
  positions.reserve(vertices);
  for (size_t p = 0; p < points.size(); ++p) {
    if (weld.VertexOf(p) == static_cast<int32_t>(positions.size())) positions.push_back(points[p]);
  }
  return positions;
}

}  // namespace meshsmooth
