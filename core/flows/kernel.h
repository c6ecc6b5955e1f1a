// Internal to core/flows: the per-vertex operators and the fused Jacobi step shared by the
// flow files. Everything here is inline so each flow's vertex loop compiles into one tight
// loop (no virtual call, no allocation per vertex).
#pragma once

#include <immintrin.h>  // declares the wide builtins used below (LaneSqrt)

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <type_traits>
#include <vector>

#include "core/flows/flow.h"
#include "core/flows/lane_batches.h"

namespace meshsmooth::flows {

// Loops over vertices run in fixed blocks of this many vertices (see ForBlocks).
inline constexpr int32_t kBlock = 4096;
static_assert(kBlock % 8 == 0, "blocks start at whole batches of the cotangent kernel");

// The instruction set the arithmetic-bound loops are compiled for (RunWithIsa).
enum class VectorIsa : uint8_t { kSse2, kAvx2, kAvx512 };

// The widest this CPU has, or a narrower one named by MESHSMOOTH_VECTOR_ISA (sse2, avx2; for
// tests and measurements).
VectorIsa BestVectorIsa();

// What a vertex does in an iteration.
enum Role : uint8_t {
  kFixed = 0,  // copies its position
  kFree = 1,   // interior vertex: moves by the flow
  kCurve = 2,  // boundary vertex in BoundaryMode::kCurve: 1-D umbrella along its loop
};

// Everything a step needs besides positions; built once per run.
struct StepContext {
  int32_t num_vertices = 0;          // size of the position arrays (0: StepRange prefetches nothing)
  const int32_t* offsets = nullptr;  // Topology::ring_offsets
  const int32_t* ring = nullptr;     // Topology::ring
  const uint8_t* role = nullptr;
  const uint8_t* all_free = nullptr;  // per block of kBlock vertices: 1 when every role is kFree
  const VertexKind* kind = nullptr;  // Topology::kind
  double lambda = 0.0;          // effective step of this pass (negative for taubin's mu pass)
  double curve_lambda = 0.0;    // step of the boundary-curve umbrella in this pass
  const double* threshold = nullptr;  // eq. (14): per-vertex T in the flow's speed units, or null
  double h = 1.0;               // mean edge length of the input
  // Curvature flows: a free vertex moves at most this far (squared) in one pass; see smooth.cc.
  double max_step_sq = std::numeric_limits<double>::infinity();
  double inv_h2 = 1.0;          // 1 / h^2
  VectorIsa isa = VectorIsa::kSse2;  // see RunWithIsa
  // The cotangent kernel's batches of free vertices (core/flows/lane_batches.h), or null.
  const LaneBatches* batches = nullptr;
};

// Displacement statistics of one block of vertices; reduced in block order, so the totals do
// not depend on the number of threads.
struct BlockStats {
  double max_sq = 0.0;
  double sum = 0.0;
  int64_t moved = 0;
  int64_t movable = 0;
  int64_t capped = 0;  // vertices whose step was capped at max_step_sq
  bool non_finite = false;
};

// A block's statistics from its step loop's running sums. Non-finite results are caught here:
// a NaN or infinite position makes its step, hence the displacement sum, non-finite (the
// positions going in are finite).
inline BlockStats FinishBlock(double max_sq, double sum, int64_t moved, int64_t movable, int64_t capped) {
  BlockStats s;
  s.max_sq = max_sq;
  s.sum = sum;
  s.moved = moved;
  s.movable = movable;
  s.capped = capped;
  s.non_finite = !std::isfinite(sum);
  return s;
}

// True when every vertex of the kBlock block starting at `begin` is free.
inline bool AllFreeBlock(const StepContext& c, int32_t begin) {
  return c.all_free != nullptr && c.all_free[begin / kBlock];
}

// Cotangents of needle triangles are clamped to this magnitude (NOTES.md, degenerate places).
inline constexpr double kCotMax = 1e3;

// Two doubles in one SSE2 register (GCC vector extension): U1 takes two ring neighbours at a
// time. SSE2 is the x86-64 baseline, so every build computes the same bits.
using Lanes = double __attribute__((vector_size(16)));

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

// W doubles, one per vertex, for the cotangent kernel below (W = 1 is a plain double). Only
// lane-wise IEEE operations are used on them, so every lane computes the bits a plain double
// computation of the same vertex would: results do not depend on W.
template <int W> struct VertexLanesOf;
template <> struct VertexLanesOf<1> { using type = double; };
template <> struct VertexLanesOf<2> { typedef double type __attribute__((vector_size(16))); };
template <> struct VertexLanesOf<4> { typedef double type __attribute__((vector_size(32))); };
template <> struct VertexLanesOf<8> { typedef double type __attribute__((vector_size(64))); };

// Square roots of the lanes. Builtins, not <immintrin.h>: its always_inline wrappers refuse to
// inline into these templates, which get their instruction set only once inlined into
// RunWithIsa's entry points.
inline double LaneSqrt(double x) { return std::sqrt(x); }
__attribute__((always_inline)) inline VertexLanesOf<2>::type LaneSqrt(VertexLanesOf<2>::type x) {
  return __builtin_ia32_sqrtpd(x);
}
__attribute__((always_inline)) inline VertexLanesOf<4>::type LaneSqrt(VertexLanesOf<4>::type x) {
  return __builtin_ia32_sqrtpd256(x);
}
__attribute__((always_inline)) inline VertexLanesOf<8>::type LaneSqrt(VertexLanesOf<8>::type x) {
  return __builtin_ia32_sqrtpd512_mask(x, x, static_cast<unsigned char>(0xff), 4 /* current rounding */);
}

// True when a[l] < b[l] in some lane: one compare and one branch, whatever W (a select on
// the comparison would be lowered to a branch per lane, see MeanCurvatureLanes).
inline bool AnyLaneLess(double a, double b) { return a < b; }
__attribute__((always_inline)) inline bool AnyLaneLess(VertexLanesOf<2>::type a, VertexLanesOf<2>::type b) {
  return __builtin_ia32_movmskpd(__builtin_ia32_cmpltpd(a, b)) != 0;
}
__attribute__((always_inline)) inline bool AnyLaneLess(VertexLanesOf<4>::type a, VertexLanesOf<4>::type b) {
  return __builtin_ia32_movmskpd256(__builtin_ia32_cmppd256(a, b, 1 /* _CMP_LT_OS */)) != 0;
}
__attribute__((always_inline)) inline bool AnyLaneLess(VertexLanesOf<8>::type a, VertexLanesOf<8>::type b) {
  return __builtin_ia32_cmppd512_mask(a, b, 1 /* _CMP_LT_OS */, static_cast<unsigned char>(0xff),
                                      4 /* current rounding */) != 0;
}

// a < b ? a : b and b < a ? a : b lane by lane (NaN in a gives b), as one instruction: GCC
// turns only some of these selects into minpd/maxpd.
inline double LaneMin(double a, double b) { return a < b ? a : b; }
inline double LaneMax(double a, double b) { return b < a ? a : b; }
__attribute__((always_inline)) inline VertexLanesOf<2>::type LaneMin(VertexLanesOf<2>::type a, VertexLanesOf<2>::type b) {
  return __builtin_ia32_minpd(a, b);
}
__attribute__((always_inline)) inline VertexLanesOf<2>::type LaneMax(VertexLanesOf<2>::type a, VertexLanesOf<2>::type b) {
  return __builtin_ia32_maxpd(a, b);
}
__attribute__((always_inline)) inline VertexLanesOf<4>::type LaneMin(VertexLanesOf<4>::type a, VertexLanesOf<4>::type b) {
  return __builtin_ia32_minpd256(a, b);
}
__attribute__((always_inline)) inline VertexLanesOf<4>::type LaneMax(VertexLanesOf<4>::type a, VertexLanesOf<4>::type b) {
  return __builtin_ia32_maxpd256(a, b);
}
__attribute__((always_inline)) inline VertexLanesOf<8>::type LaneMin(VertexLanesOf<8>::type a, VertexLanesOf<8>::type b) {
  return __builtin_ia32_minpd512_mask(a, b, a, static_cast<unsigned char>(0xff), 4 /* current rounding */);
}
__attribute__((always_inline)) inline VertexLanesOf<8>::type LaneMax(VertexLanesOf<8>::type a, VertexLanesOf<8>::type b) {
  return __builtin_ia32_maxpd512_mask(a, b, a, static_cast<unsigned char>(0xff), 4 /* current rounding */);
}

// W int32 lanes beside them: vertex and ring indices.
template <int W> struct IndexLanesOf;
template <> struct IndexLanesOf<1> { using type = int32_t; };
template <> struct IndexLanesOf<2> { typedef int32_t type __attribute__((vector_size(8))); };
template <> struct IndexLanesOf<4> { typedef int32_t type __attribute__((vector_size(16))); };
template <> struct IndexLanesOf<8> { typedef int32_t type __attribute__((vector_size(32))); };

// Lane l holds base[index[l]] where live[l] (a comparison of lanes), else fallback[l]; lanes
// that are not live read no memory.
template <int W>
__attribute__((always_inline)) inline typename IndexLanesOf<W>::type GatherIndexLanes(
    const int32_t* base, const typename IndexLanesOf<W>::type& index, const typename IndexLanesOf<W>::type& live,
    const typename IndexLanesOf<W>::type& fallback) {
  using I = typename IndexLanesOf<W>::type;
  if constexpr (W == 1) {
    return live ? base[index] : fallback;
  } else if constexpr (W == 2) {
    return I{live[0] ? base[index[0]] : fallback[0], live[1] ? base[index[1]] : fallback[1]};
  } else if constexpr (W == 4) {
    return __builtin_ia32_gathersiv4si(fallback, base, index, live, 4);
  } else {
    return __builtin_ia32_gathersiv8si(fallback, base, index, live, 4);
  }
}

// Lane l holds base[index[l]]: gather instructions for AVX2 and AVX-512, loads otherwise.
template <int W>
__attribute__((always_inline)) inline typename VertexLanesOf<W>::type GatherLanes(
    const double* base, const typename IndexLanesOf<W>::type& index) {
  using V = typename VertexLanesOf<W>::type;
  if constexpr (W == 1) {
    return base[index];
  } else if constexpr (W == 2) {
    return V{base[index[0]], base[index[1]]};
  } else if constexpr (W == 4) {
    return __builtin_ia32_gathersiv4df(V{}, base, index, V{} == V{}, 8);
  } else {
    return __builtin_ia32_gathersiv8df(V{}, base, index, static_cast<unsigned char>(0xff), 8);
  }
}

// The x, y and z of positions index3[l] / 3, lane by lane. With 8 lanes, eight masked loads of
// one position each (3 doubles; masked-off elements never fault past the array's end)
// transposed by shuffles instead of three gathers. The same values either way.
template <int W>
__attribute__((always_inline)) inline void GatherXyzLanes(const double* base, const typename IndexLanesOf<W>::type& index3,
                                                          typename VertexLanesOf<W>::type& x,
                                                          typename VertexLanesOf<W>::type& y,
                                                          typename VertexLanesOf<W>::type& z) {
  if constexpr (W == 8) {
    using V = typename VertexLanesOf<8>::type;
    typedef long long Select __attribute__((vector_size(64)));
    const unsigned char xyz = 0x07;
    const V l0 = __builtin_ia32_loadupd512_mask(base + index3[0], V{}, xyz),
            l1 = __builtin_ia32_loadupd512_mask(base + index3[1], V{}, xyz),
            l2 = __builtin_ia32_loadupd512_mask(base + index3[2], V{}, xyz),
            l3 = __builtin_ia32_loadupd512_mask(base + index3[3], V{}, xyz),
            l4 = __builtin_ia32_loadupd512_mask(base + index3[4], V{}, xyz),
            l5 = __builtin_ia32_loadupd512_mask(base + index3[5], V{}, xyz),
            l6 = __builtin_ia32_loadupd512_mask(base + index3[6], V{}, xyz),
            l7 = __builtin_ia32_loadupd512_mask(base + index3[7], V{}, xyz);
    // l_i = (x_i, y_i, z_i, 0, ...): two lanes per register, then x and y of four lanes, then all.
    const Select pair{0, 1, 2, 3, 8, 9, 10, 11}, xy{0, 4, 8, 12, 1, 5, 9, 13}, zz{2, 6, 10, 14, 2, 6, 10, 14},
                 low{0, 1, 2, 3, 8, 9, 10, 11}, high{4, 5, 6, 7, 12, 13, 14, 15};
    const V p01 = __builtin_shuffle(l0, l1, pair), p23 = __builtin_shuffle(l2, l3, pair),
            p45 = __builtin_shuffle(l4, l5, pair), p67 = __builtin_shuffle(l6, l7, pair);
    const V xy0 = __builtin_shuffle(p01, p23, xy), xy1 = __builtin_shuffle(p45, p67, xy);
    const V z0 = __builtin_shuffle(p01, p23, zz), z1 = __builtin_shuffle(p45, p67, zz);
    x = __builtin_shuffle(xy0, xy1, low);
    y = __builtin_shuffle(xy0, xy1, high);
    z = __builtin_shuffle(z0, z1, low);
  } else {
    x = GatherLanes<W>(base, index3), y = GatherLanes<W>(base + 1, index3), z = GatherLanes<W>(base + 2, index3);
  }
}

// Eq. (8) with the mixed Voronoi area of Meyer et al. in place of A/3 (NOTES.md): on a sphere
// of radius r, |H n| = 1/r. Zero-area triangles contribute nothing; cotangents are clamped.
// Meaningful only for interior vertices (closed ring); finite for any vertex.
//
// Computed for the W vertices first, ..., first + count - 1 (count <= W) at once, one vertex
// per lane (the cotangent flows are arithmetic-bound: ~70 operations per triangle of the
// ring). Step k takes triangle (P, Q_{k-1}, Q_k) of every lane's ring; a lane whose ring is
// shorter loads its own P as Q_k, so it gets the triangles (P, Q_{n-1}, P), then (P, P, P):
// q = 0 and a zero cross product make every term it adds a signed zero (its area term is
// dropped: `ok` is false). The sums start at +0, so they are never -0, and adding +-0 to them
// changes nothing: the lane's bits are those of its vertex computed alone. (Selecting a = 0
// for those steps cost 4% of mcf at 41k vertices.) Lanes past `count` repeat the first vertex.
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
      begin = GatherIndexLanes<W>(c.offsets, self, all, self), end = GatherIndexLanes<W>(c.offsets, self + 1, all, self);
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
    if constexpr (W == 8) {  // by halves: three maxima instead of seven extracts
      typedef int32_t Half __attribute__((vector_size(16)));
      Half m = __builtin_ia32_pmaxsd128(Half{n[0], n[1], n[2], n[3]}, Half{n[4], n[5], n[6], n[7]});
      m = __builtin_ia32_pmaxsd128(m, __builtin_shuffle(m, Half{2, 3, 0, 1}));
      m = __builtin_ia32_pmaxsd128(m, __builtin_shuffle(m, Half{1, 0, 3, 2}));
      max_valence = m[0];
    } else {
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
  // the position gathers sat on every step's critical path: the kernel alone over a 41k mesh
  // in cache, 8 lanes, took 25.6 ns per vertex, 19.8 ns with the loads ahead.
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
    at += 1;  // Q_{k+1}; a lane past its ring loads its own P, as above
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
// prefetches the neighbours of the vertices kRingPrefetchAhead further on. mcf at 655k
// vertices, 1 thread: 31 -> 22 ms per iteration; 16 to 96 vertices ahead all measure the same.
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

// The speed of a cotangent flow at vertex v, for StepRange: F = finish(CurvatureLanes<V>), a
// function of lanes like MeanCurvatureLanes (so its divisions and selects run W vertices at a
// time, without a branch per vertex), computed W vertices at a time. StepRange asks for
// increasing v, so one batch serves the next W vertices.
template <int W, typename FinishFn>
class CurvatureSpeed {
 public:
  CurvatureSpeed(const StepContext& c, const Vec3* pos, int32_t begin, int32_t end, FinishFn& finish)
      : c_(c), pos_(pos), end_(end), first_(begin - W), finish_(finish) {}
  __attribute__((always_inline)) Vec3 operator()(int32_t v) {
    if (v - first_ >= W) {
      first_ = v;
      PrefetchRingsAhead(c_, pos_, v, W, end_);
      const int32_t count = std::min<int32_t>(W, end_ - v);
      // Whole-register stores, read back per vertex: taking lanes out one by one lets GCC
      // turn finish's selects into one branch per lane.
      const auto f = finish_(MeanCurvatureLanes<W>(c_, pos_, v, count));
      std::memcpy(x_, &f.x, sizeof(x_));
      std::memcpy(y_, &f.y, sizeof(y_));
      std::memcpy(z_, &f.z, sizeof(z_));
    }
    const int32_t l = v - first_;
    return {x_[l], y_[l], z_[l]};
  }

 private:
  const StepContext& c_;
  const Vec3* pos_;
  int32_t end_, first_;
  FinishFn& finish_;
  alignas(8 * W) double x_[W], y_[W], z_[W];
};

// Eq. (14): shortens F by T, or stops the vertex when |F| <= T.
inline Vec3 Threshold(const Vec3& f, double t) {
  const double len = Norm(f);
  return len > t ? f * ((len - t) / len) : Vec3{};
}

// Loops reading positions at the neighbours of each vertex (StepRange, bilaplacian's U0 field)
// prefetch the positions this many vertices ahead of the one they compute. In Morton
// order most neighbours lie within a few thousand vertices of a vertex, on either side; those
// behind were read recently, those ahead are not yet in cache and the hardware prefetcher
// (which follows the sequential stream only a few lines ahead) does not fetch them. Scratch,
// plain U0 loop at 2.6M vertices: 29.9 -> 15.0 ms per iteration on 1 thread, 13.6 -> 7.1 ms on
// 2, with 4096 (256: 20.0 / 9.2, 1024: 16.9 / 7.9, 16384: 15.5 / 8.6).
inline constexpr int32_t kPositionPrefetchAhead = 4096;

// Called for every vertex v of a loop over [0, n) reading pos at v's neighbours: one prefetch
// of 8 positions (192 bytes, three cache lines) every 8 vertices.
__attribute__((always_inline)) inline void PrefetchPositionsAhead(const Vec3* pos, int32_t v, int32_t n) {
  if ((v & 7) == 0 && v < n - kPositionPrefetchAhead - 8) {
    const char* ahead = reinterpret_cast<const char*>(pos + v + kPositionPrefetchAhead);
    __builtin_prefetch(ahead);
    __builtin_prefetch(ahead + 64);
    __builtin_prefetch(ahead + 128);
  }
}

// The fused Jacobi step over vertices [begin, end): next = cur + lambda F for free vertices,
// the boundary-curve umbrella for curve vertices, a copy for fixed ones, with the block's
// displacement statistics. kAllFree: every vertex of the range is free (most blocks of a
// closed mesh), so the role branch goes. Non-finite results are caught once per block
// (FinishBlock).
template <bool kAllFree, typename SpeedFn>
__attribute__((always_inline)) inline BlockStats StepRange(const StepContext& c, const Vec3* cur, Vec3* next,
                                                           int32_t begin, int32_t end, SpeedFn&& speed) {
  // Locals, not c's fields or the returned struct: the stores to next[] could alias those
  // doubles, which would force a reload or store of each per vertex.
  const double lambda = c.lambda, curve_lambda = c.curve_lambda, max_step_sq = c.max_step_sq;
  const double* const threshold = c.threshold;
  const uint8_t* const role_of = c.role;
  double max_sq = 0.0, sum = 0.0;
  int64_t moved = 0, movable = 0, capped = 0;
  // The lengths of the steps are summed in vertex order, but square-rooted two at a time (one
  // sqrtpd instead of two sqrtsd: the same bits). `held` is the squared length waiting for its
  // pair, or negative.
  double held = -1.0;
  const int32_t n = c.num_vertices;
  for (int32_t v = begin; v < end; ++v) {
    PrefetchPositionsAhead(cur, v, n);
    const uint8_t role = kAllFree ? uint8_t{kFree} : role_of[v];
    if (role == kFixed) {
      next[v] = cur[v];
      continue;
    }
    Vec3 step;
    if (role == kFree) {
      Vec3 f = speed(v);
      if (threshold != nullptr) f = Threshold(f, threshold[v]);
      step = f * lambda;
      const double len2 = SquaredNorm(step);
      if (len2 > max_step_sq) {
        step *= std::sqrt(max_step_sq / len2);
        ++capped;
      }
    } else {
      step = CurveUmbrella(c, cur, v) * curve_lambda;
    }
    next[v] = cur[v] + step;
    const double d2 = SquaredNorm(step);
    max_sq = std::max(max_sq, d2);
    if (held < 0.0) {
      held = d2;
    } else {
      const Lanes root = __builtin_ia32_sqrtpd(Lanes{held, d2});
      sum += root[0];
      sum += root[1];
      held = -1.0;
    }
    moved += d2 > 0.0;
    if (!kAllFree) ++movable;
  }
  if (held >= 0.0) sum += std::sqrt(held);
  return FinishBlock(max_sq, sum, moved, kAllFree ? end - begin : movable, capped);
}

template <typename SpeedFn>
__attribute__((always_inline)) inline BlockStats ApplyStep(const StepContext& c, const Vec3* cur, Vec3* next,
                                                           int32_t begin, int32_t end, SpeedFn&& speed) {
  if (AllFreeBlock(c, begin)) return StepRange<true>(c, cur, next, begin, end, speed);
  return StepRange<false>(c, cur, next, begin, end, speed);
}

// fn(width) compiled for `isa`, with width a std::integral_constant<int, W>: the number of
// doubles in one register of that instruction set (2 for the SSE2 baseline, 4 for AVX2, 8 for
// AVX-512). The entry points are flattened, so fn and everything it calls is compiled into
// them. No FMA is ever formed (core is built with -ffp-contract=off), and the cotangent kernel
// computes each vertex in its own lane: the same bits whichever runs.
template <int W>
using LaneWidth = std::integral_constant<int, W>;
template <class Fn>
__attribute__((target("avx512f,avx512vl,avx512dq"), flatten)) BlockStats RunAvx512(const Fn& fn) {
  return fn(LaneWidth<8>{});
}
template <class Fn>
__attribute__((target("avx2"), flatten)) BlockStats RunAvx2(const Fn& fn) {
  return fn(LaneWidth<4>{});
}
template <class Fn>
__attribute__((always_inline)) inline BlockStats RunWithIsa(VectorIsa isa, const Fn& fn) {
  if (isa == VectorIsa::kAvx512) return RunAvx512(fn);
  if (isa == VectorIsa::kAvx2) return RunAvx2(fn);
  return fn(LaneWidth<2>{});
}

// The W that RunWithIsa passes for `isa` (the cotangent kernel's lanes).
inline int LaneWidthOf(VectorIsa isa) { return isa == VectorIsa::kAvx512 ? 8 : isa == VectorIsa::kAvx2 ? 4 : 2; }

// StepRange for a cotangent flow, over the block's batches of free vertices
// (c.batches, BuildLaneBatches; W = its width): the speed, the step, its cap and the
// displacement statistics in lanes, stored per vertex; then one loop over the block in vertex
// order copies the fixed vertices, moves the curve vertices and adds the statistics. Per
// vertex the operations are those of StepRange (the cap as a factor min(1, sqrt(max / len2)),
// which is 1 exactly when the step is not capped), in the same order, so the bits are too.
// kAllFree: every vertex of the block is free (no role to look at).
//
// Measured (scratch Smooth() timing, mcf, 1 thread): through CurvatureSpeed, the per-vertex
// step around the kernel cost about as much again as the kernel. On the dragon scan, whose 1%
// of boundary vertices leave 46 of its 107 blocks not all free, taking those blocks here too
// took mcf from 10.35-10.75 to 9.56-9.68 ms per iteration.
template <int W, bool kAllFree, typename FinishFn>
__attribute__((always_inline)) inline BlockStats CurvatureStepLanes(const StepContext& c, const Vec3* cur, Vec3* next,
                                                                    int32_t begin, int32_t end, FinishFn& finish) {
  using V = typename VertexLanesOf<W>::type;
  const double lambda = c.lambda, curve_lambda = c.curve_lambda, max_step_sq = c.max_step_sq;
  const uint8_t* const role_of = c.role;
  const int32_t n = c.num_vertices;
  const double* const threshold = c.threshold;
  const V zero{}, one = zero + 1.0, max_sq_lanes = zero + max_step_sq;
  const LaneBatches& lanes = *c.batches;
  const int32_t block = begin / kBlock, first_batch = lanes.block_first[block], last_batch = lanes.block_first[block + 1];
  // Per vertex of the block (offset from begin): a free vertex's squared step, its length and
  // whether it was capped.
  alignas(64) double d2_at[kBlock], root_at[kBlock];
  alignas(64) uint8_t capped_at[kBlock];
  alignas(8 * W) double sx[W], sy[W], sz[W], len2_of[W], d2_of[W], root_of[W];
  for (int32_t j = first_batch; j < last_batch; ++j) {
    // The batches run through the block's vertices out of order: prefetch as if in order.
    PrefetchPositionsAhead(cur, begin + (j - first_batch) * W, n);
    if (j + kBatchPrefetchAhead < last_batch) PrefetchBatchRing(lanes, cur, j + kBatchPrefetchAhead);
    const int32_t* const rows = &lanes.data[lanes.offsets[j]];
    const auto f = finish(MeanCurvatureLanes<W, true>(c, cur, 0, W, rows));
    V fx = f.x, fy = f.y, fz = f.z;
    if (threshold != nullptr) {  // eq. (14) as Threshold(), lane by lane
      typename IndexLanesOf<W>::type self;
      std::memcpy(&self, rows, sizeof self);
      const V t = GatherLanes<W>(threshold, self);
      const V len = LaneSqrt(fx * fx + fy * fy + fz * fz);
      const V shorten = (len - t) / len;
      const auto keep = t < len;
      fx = keep ? fx * shorten : zero, fy = keep ? fy * shorten : zero, fz = keep ? fz * shorten : zero;
    }
    V x = fx * lambda, y = fy * lambda, z = fz * lambda;
    const V len2 = x * x + y * y + z * z;
    V d2 = len2;
    // The factor is 1 in every lane whose len2 <= max_step_sq (or NaN): x * 1 == x and d2 ==
    // len2, so the division and square root are skipped unless some lane is capped (rare:
    // mcf at 41k vertices, 1.02 -> 0.93 ms per iteration).
    if (AnyLaneLess(max_sq_lanes, len2)) {
      V factor = LaneSqrt(max_sq_lanes / len2);
      factor = factor < one ? factor : one;
      x = x * factor, y = y * factor, z = z * factor;
      d2 = x * x + y * y + z * z;
    }
    const V root = LaneSqrt(d2);
    std::memcpy(sx, &x, sizeof sx);
    std::memcpy(sy, &y, sizeof sy);
    std::memcpy(sz, &z, sizeof sz);
    std::memcpy(len2_of, &len2, sizeof len2_of);
    std::memcpy(d2_of, &d2, sizeof d2_of);
    std::memcpy(root_of, &root, sizeof root_of);
    for (int32_t l = 0, count = lanes.lanes[j]; l < count; ++l) {
      const int32_t v = rows[l], at = v - begin;
      next[v] = cur[v] + Vec3{sx[l], sy[l], sz[l]};
      d2_at[at] = d2_of[l];
      root_at[at] = root_of[l];
      capped_at[at] = len2_of[l] > max_step_sq;
    }
  }
  double max_sq = 0.0, sum = 0.0;
  int64_t moved = 0, movable = 0, capped = 0;
  for (int32_t v = begin; v < end; ++v) {  // StepRange's roles and statistics, in vertex order
    const int32_t at = v - begin;
    const uint8_t role = kAllFree ? uint8_t{kFree} : role_of[v];
    double d2;
    if (role == kFree) {
      d2 = d2_at[at];
      sum += root_at[at];
      capped += capped_at[at];
    } else if (role == kFixed) {
      next[v] = cur[v];
      continue;
    } else {
      const Vec3 step = CurveUmbrella(c, cur, v) * curve_lambda;
      next[v] = cur[v] + step;
      d2 = SquaredNorm(step);
      sum += std::sqrt(d2);
    }
    max_sq = std::max(max_sq, d2);
    moved += d2 > 0.0;
    ++movable;
  }
  return FinishBlock(max_sq, sum, moved, movable, capped);
}

// The step of a cotangent flow, F = finish(CurvatureLanes<V>) (see CurvatureSpeed), compiled
// for c.isa (RunWithIsa). finish is generic over V and must use only lane-wise operations,
// `<` comparisons and one comparison per select (see MeanCurvatureLanes).
// `finish` should be always_inline: GCC's flatten stops at a lambda whose inlined body would
// grow the stack frame too much, and that lambda would then run as baseline code called from
// the wide entry point.
template <typename FinishFn>
__attribute__((always_inline)) inline BlockStats ApplyCurvatureStep(const StepContext& c, const Vec3* cur, Vec3* next,
                                                                    int32_t begin, int32_t end, FinishFn&& finish) {
  return RunWithIsa(c.isa, [&](auto width) __attribute__((always_inline)) {
    constexpr int W = decltype(width)::value;
    if (c.batches != nullptr && c.batches->width == W) {
      if (AllFreeBlock(c, begin)) return CurvatureStepLanes<W, true>(c, cur, next, begin, end, finish);
      return CurvatureStepLanes<W, false>(c, cur, next, begin, end, finish);
    }
    CurvatureSpeed<W, FinishFn> speed(c, cur, begin, end, finish);
    return ApplyStep(c, cur, next, begin, end, speed);
  });
}

// One flow: how one pass moves the vertices of a block. Flow files implement it.
class FlowKernel {
 public:
  virtual ~FlowKernel() = default;
  // Passes per iteration and each pass's step factor (taubin: 1 and -mu/lambda).
  virtual int passes() const { return 1; }
  virtual double pass_factor(int /*pass*/) const { return 1.0; }
  // True for the curvature flows: step relative to h^2, speed in 1/length.
  virtual bool curvature_units() const = 0;
  // Work over all vertices before a pass's blocks (bilaplacian: U at every vertex).
  virtual void Prepare(const StepContext& /*c*/, const Vec3* /*cur*/, int32_t /*n*/, int /*threads*/) {}
  virtual BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const = 0;
};

std::unique_ptr<FlowKernel> MakeLaplacian(const FlowParams& p);
std::unique_ptr<FlowKernel> MakeTaubin(const FlowParams& p, double lambda, double mu);
std::unique_ptr<FlowKernel> MakeBilaplacian(const FlowParams& p);
std::unique_ptr<FlowKernel> MakeMcf(const FlowParams& p);
std::unique_ptr<FlowKernel> MakeMcfTangential(const FlowParams& p);
std::unique_ptr<FlowKernel> MakeMedian(const FlowParams& p);

// Eq. (14)'s T(P): mean |H| over the first ring (rings = 1) or the first and second rings
// (rings = 2) of every vertex, over interior neighbours only; written to `t`.
void RingThresholds(const StepContext& c, const Vec3* pos, int32_t n, int rings, int threads, std::vector<double>& t);

// Runs fn(block, begin, end) over [0, n) in fixed blocks of kBlock vertices on up to
// `threads` threads. Block boundaries do not depend on the thread count, so per-block results
// reduced in block order are deterministic.

template <typename Fn>
void ForBlocks(int32_t n, int threads, Fn&& fn) {
  const int32_t blocks = (n + kBlock - 1) / kBlock;
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && blocks > 1)
  for (int32_t b = 0; b < blocks; ++b) fn(b, b * kBlock, std::min(n, (b + 1) * kBlock));
}

}  // namespace meshsmooth::flows
