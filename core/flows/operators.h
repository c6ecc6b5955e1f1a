// Internal to core/flows: the per-vertex operators of the paper that the flows are made of:
// U0 (eq. 3), U1 (eq. 4), the boundary-curve umbrella, and the mean-curvature normal of
// eq. (8) computed W vertices at a time (MeanCurvatureLanes), with the prefetching its loops
// need. Everything is inline so each flow's vertex loop compiles into one tight loop.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "core/flows/flow_kernel.h"
#include "core/flows/lane_batches.h"
#include "core/flows/lanes.h"

namespace meshsmooth::flows {

// Cotangents of needle triangles are clamped to this magnitude (docs/paper.md, degenerate places).
inline constexpr double kCotMax = 1e3;

// 1.0 / k for the valences most vertices have, without a division per vertex. Constant folding
// rounds correctly, as the division does: the same bits.
inline constexpr int32_t kReciprocals = 64;
inline constexpr auto kReciprocal = [] {
  std::array<double, kReciprocals> r{};
  for (int32_t k = 1; k < kReciprocals; ++k) r[k] = 1.0 / k;
  return r;
}();
inline double Reciprocal(int32_t k) { return k < kReciprocals ? kReciprocal[k] : 1.0 / k; }

// U0, eq. (3). Two running sums halve the chain of dependent additions (the loads of the
// neighbours then overlap); the order is fixed, so results do not depend on threads.
inline Vec3 UmbrellaU0(const StepContext& c, const Vec3* pos, int32_t v) {
  const int32_t b = c.offsets[v], e = c.offsets[v + 1];
  Vec3 even, odd;
  int32_t i = b;
  for (; i + 1 < e; i += 2) {
    even += pos[c.ring[i]];
    odd += pos[c.ring[i + 1]];
  }
  if (i < e) even += pos[c.ring[i]];
  return (even + odd) * Reciprocal(e - b) - pos[v];
}

// U1, eq. (4): weights 1/|P - Q|, with coincident neighbours given the weight of a 1e-9 h edge.
// Two neighbours at a time: one sqrtpd and one divpd per pair.
__attribute__((always_inline)) inline Vec3 UmbrellaU1(const StepContext& c, const Vec3* pos, int32_t v) {
  const int32_t b = c.offsets[v], e = c.offsets[v + 1];
  const Vec3 p = pos[v];
  const Lanes floor = Lanes{} + 1e-9 * c.h;
  Lanes sx{}, sy{}, sz{}, wsum{};
  for (int32_t i = b; i < e; i += 2) {
    const Vec3 d0 = pos[c.ring[i]] - p;
    const Vec3 d1 = i + 1 < e ? pos[c.ring[i + 1]] - p : Vec3{};
    const Lanes dx{d0.x, d1.x}, dy{d0.y, d1.y}, dz{d0.z, d1.z};
    const Lanes len = __builtin_ia32_maxpd(__builtin_ia32_sqrtpd(dx * dx + dy * dy + dz * dz), floor);
    const Lanes live{1.0, i + 1 < e ? 1.0 : 0.0};  // the padding lane weighs nothing
    const Lanes w = live / len;
    sx += dx * w, sy += dy * w, sz += dz * w;
    wsum += w;
  }
  return Vec3{sx[0] + sx[1], sy[0] + sy[1], sz[0] + sz[1]} * (1.0 / (wsum[0] + wsum[1]));
}

// The 1-D umbrella of a boundary vertex: midpoint of its two loop neighbours minus P.
inline Vec3 CurveUmbrella(const StepContext& c, const Vec3* pos, int32_t v) {
  return (pos[c.ring[c.offsets[v]]] + pos[c.ring[c.offsets[v + 1] - 1]]) * 0.5 - pos[v];
}

struct Curvature {
  Vec3 hn;      // mean-curvature normal H n: |hn| = H, pointing to the centre of curvature
  Vec3 normal;  // area-weighted face normal (not normalised; orientation of the ring)
  Vec3 u0;      // U0 of eq. (3), mean of Q_k - P, from the same pass over the ring
};

// Vec3s of W vertices, one per lane: V is a double or a vector of doubles (VertexLanesOf).
template <typename V>
struct LaneVec3 {
  V x, y, z;
};

// Curvature of W vertices, one per lane.
template <typename V>
struct CurvatureLanes {
  LaneVec3<V> hn, normal, u0;
};

// Eq. (8) with the mixed Voronoi area of Meyer et al. in place of A/3 (docs/paper.md): on a sphere
// of radius r, |H n| = 1/r. Zero-area triangles contribute nothing; cotangents are clamped.
// Meaningful only for interior vertices (closed ring); finite for any vertex.
//
// Computed for the W vertices first, ..., first + count - 1 (count <= W) at once, one vertex
// per lane (the cotangent flows are arithmetic-bound: ~70 operations per triangle of the
// ring). Step k takes triangle (P, Q_{k-1}, Q_k) of every lane's ring; a lane whose ring is
// shorter loads its own P as Q_k, so it gets the triangles (P, Q_{n-1}, P), then (P, P, P):
// q = 0 and a zero cross product make every term it adds a signed zero (its area term is
// dropped: `ok` is false). The sums start at +0, so they are never -0, and adding +-0 to them
// changes nothing: the lane's bits are those of its vertex computed alone (cheaper than
// selecting a = 0 for those steps). Lanes past `count` repeat the first vertex.
//
// With kLaneRows, the vertices, their valences and every index come from `rows`, a batch of
// BuildLaneBatches (first and count are unused), instead of gathers from c.offsets and c.ring:
// the same values.
template <int W, bool kLaneRows = false>
__attribute__((always_inline)) inline CurvatureLanes<typename VertexLanesOf<W>::type> MeanCurvatureLanes(
    const StepContext& c, const Vec3* pos, int32_t first, int32_t count, const int32_t* rows = nullptr) {
  using V = typename VertexLanesOf<W>::type;
  using I = typename IndexLanesOf<W>::type;
  const double* const base = &pos[0].x;
  I self, begin, end;
  if constexpr (kLaneRows) {
    std::memcpy(&self, rows, sizeof self);
    std::memcpy(&end, rows + W, sizeof end);  // the valences
    begin = I{};
    rows += 2 * W;
  } else if constexpr (W == 1) {
    self = first;
  } else {
    I lane;
    for (int l = 0; l < W; ++l) lane[l] = l;  // a constant
    self = lane < count ? first + lane : first + I{};
  }
  const I self3 = 3 * self;
  if constexpr (!kLaneRows) {
    if (count == W) {  // consecutive vertices: their offsets are too
      std::memcpy(&begin, c.offsets + first, sizeof begin);
      std::memcpy(&end, c.offsets + first + 1, sizeof end);
    } else {
      const I all = self == self;
      begin = GatherIndexLanes<W>(c.offsets, self, all, self),
      end = GatherIndexLanes<W>(c.offsets, self + 1, all, self);
    }
  }
  V valence;
  int32_t max_valence;
  if constexpr (W == 1) {
    valence = end - begin;
    max_valence = end - begin;
  } else {
    const I n = end - begin;
    valence = __builtin_convertvector(n, V);
#if MESHSMOOTH_WIDE_LANES
    if constexpr (W == 8) {  // by halves: three maxima instead of seven extracts
      typedef int32_t Half __attribute__((vector_size(16)));
      Half m = __builtin_ia32_pmaxsd128(Half{n[0], n[1], n[2], n[3]}, Half{n[4], n[5], n[6], n[7]});
      m = __builtin_ia32_pmaxsd128(m, __builtin_shuffle(m, Half{2, 3, 0, 1}));
      m = __builtin_ia32_pmaxsd128(m, __builtin_shuffle(m, Half{1, 0, 3, 2}));
      max_valence = m[0];
    } else
#endif
    {
      max_valence = n[0];
      for (int l = 1; l < W; ++l) max_valence = std::max(max_valence, n[l]);
    }
  }
  V px, py, pz;
  GatherXyzLanes<W>(base, self3, px, py, pz);
  // Q_{-1} = Q_{n-1}: the ring is closed. index3 = 3 ring[at] (where Q's x sits in pos[]); a
  // lane past its valence loads its own P (q = 0).
  I index3;
  if constexpr (kLaneRows) {
    std::memcpy(&index3, rows, sizeof index3);
  } else {
    index3 = 3 * GatherIndexLanes<W>(c.ring, end - 1, begin < end, self);
  }
  V prev_x, prev_y, prev_z;
  GatherXyzLanes<W>(base, index3, prev_x, prev_y, prev_z);
  prev_x -= px, prev_y -= py, prev_z -= pz;
  V prev_len2 = prev_x * prev_x + prev_y * prev_y + prev_z * prev_z;  // |a|^2 is the last step's |q|^2
  const V zero{}, one = zero + 1.0, cot_max = zero + kCotMax;
  V sx{}, sy{}, sz{}, nx{}, ny{}, nz{}, ux{}, uy{}, uz{}, area{};
  // The loads run one step ahead of the arithmetic: step k computes with Q_k, loaded during
  // step k - 1, while Q_{k+1} loads. Loaded in the step that used them, the index gather and
  // the position gathers would sit on every step's critical path.
  I at = begin;
  if constexpr (kLaneRows) {
    std::memcpy(&index3, rows + W, sizeof index3);
  } else {
    index3 = 3 * GatherIndexLanes<W>(c.ring, at, at < end, self);
  }
  V next_x, next_y, next_z;
  GatherXyzLanes<W>(base, index3, next_x, next_y, next_z);
  for (int32_t k = 0; k < max_valence; ++k) {
    // Edges a = Q_{k-1} - P and q = Q_k - P.
    const V qx = next_x - px, qy = next_y - py, qz = next_z - pz;
    at += 1;                    // Q_{k+1}; a lane past its ring loads its own P, as above
    if (k + 1 < max_valence) {  // none after the last step
      if constexpr (kLaneRows) {
        std::memcpy(&index3, rows + (k + 2) * W, sizeof index3);
      } else {
        index3 = 3 * GatherIndexLanes<W>(c.ring, at, at < end, self);
      }
      GatherXyzLanes<W>(base, index3, next_x, next_y, next_z);
    }
    const V ax = prev_x, ay = prev_y, az = prev_z, la = prev_len2, lq = qx * qx + qy * qy + qz * qz;
    prev_x = qx, prev_y = qy, prev_z = qz, prev_len2 = lq;
    ux += qx, uy += qy, uz += qz;
    const V cx = ay * qz - az * qy, cy = az * qx - ax * qz, cz = ax * qy - ay * qx;
    nx += cx, ny += cy, nz += cz;
    const V dbl_area = LaneSqrt(cx * cx + cy * cy + cz * cz);
    // Angle at Q_{k-1} is opposite edge P-Q_k, angle at Q_k opposite edge P-Q_{k-1}; with
    // d = q - a their dot products are -a.d = la - a.q and q.d = lq - a.q.
    const V dot_p = ax * qx + ay * qy + az * qz, dot_a = la - dot_p, dot_q = lq - dot_p;
    const auto ok = 1e-12 * (la + lq) < dbl_area;
    const V inv = ok ? one / dbl_area : zero;  // a degenerate triangle gets cotangents 0
    V cot_a = dot_a * inv, cot_q = dot_q * inv;
    cot_a = LaneMax(LaneMin(cot_a, cot_max), -cot_max);
    cot_q = LaneMax(LaneMin(cot_q, cot_max), -cot_max);
    sx += qx * cot_a + ax * cot_q, sy += qy * cot_a + ay * cot_q, sz += qz * cot_a + az * cot_q;
    // Voronoi region of a non-obtuse triangle, else half (obtuse at P) or a quarter of its area.
    // Only `<`, and one comparison per select: GCC 12 lowers other comparisons of 512-bit
    // vectors, and selects on an & or | of masks, to one branch per lane.
    const V voronoi = (lq * cot_a + la * cot_q) * 0.125;
    const V part = dbl_area * (dot_p < zero ? zero + 0.25 : zero + 0.125);
    const V least = LaneMin(dot_p, LaneMin(dot_a, dot_q));
    const V region = least < zero ? part : voronoi;
    area += ok ? region : zero;
  }
  const V inv_n = zero < valence ? one / valence : zero;
  ux *= inv_n, uy *= inv_n, uz *= inv_n;
  const auto curved = zero < area;
  const V scale = curved ? 0.25 / area : zero;
  sx = curved ? sx * scale : zero, sy = curved ? sy * scale : zero, sz = curved ? sz * scale : zero;
  return {{sx, sy, sz}, {nx, ny, nz}, {ux, uy, uz}};
}

// One vertex's MeanCurvatureLanes.
inline Curvature MeanCurvatureNormal(const StepContext& c, const Vec3* pos, int32_t v) {
  const CurvatureLanes<double> k = MeanCurvatureLanes<1>(c, pos, v, 1);
  return {{k.hn.x, k.hn.y, k.hn.z}, {k.normal.x, k.normal.y, k.normal.z}, {k.u0.x, k.u0.y, k.u0.z}};
}

// The loads of a batch of the cotangent kernel wait on the cache misses of its neighbours'
// positions (the arithmetic leaves the core too few loads in flight to hide them): each batch
// prefetches the neighbours of the vertices kRingPrefetchAhead further on (16 to 96 vertices
// ahead all measure the same: docs/decisions.md, "Speed").
inline constexpr int32_t kRingPrefetchAhead = 32;
inline constexpr int32_t kBatchPrefetchAhead = 4;  // batches of CurvatureStepLanes: 32 vertices with 8 lanes

// Prefetches the positions of the neighbours of vertices [v + kRingPrefetchAhead, + count).
__attribute__((always_inline)) inline void PrefetchRingsAhead(const StepContext& c, const Vec3* pos, int32_t v,
                                                              int32_t count, int32_t end) {
  if (v + kRingPrefetchAhead + count <= end) {
    for (int32_t i = c.offsets[v + kRingPrefetchAhead], e = c.offsets[v + kRingPrefetchAhead + count]; i < e; ++i) {
      __builtin_prefetch(&pos[c.ring[i]]);
    }
  }
}

// Prefetches the positions of the ring entries of batch j (its rows from 3 W on).
__attribute__((always_inline)) inline void PrefetchBatchRing(const LaneBatches& lanes, const Vec3* pos, int32_t j) {
  const int32_t* const rows = &lanes.data[lanes.offsets[j]];
  const double* const base = &pos[0].x;
  for (int64_t i = 3 * lanes.width, e = lanes.offsets[j + 1] - lanes.offsets[j]; i < e; ++i) {
    __builtin_prefetch(base + rows[i]);
  }
}

}  // namespace meshsmooth::flows
