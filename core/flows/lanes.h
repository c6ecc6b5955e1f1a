// Internal to core/flows: W doubles (or int32s) in one register, one vertex per lane, for the
// cotangent kernel (core/flows/operators.h), and the gathers that fill them. Only lane-wise
// IEEE operations are used on them, so every lane computes the bits a plain double
// computation of the same vertex would.
#pragma once

#include <immintrin.h>  // declares the wide builtins used below (LaneSqrt)

#include <cmath>
#include <cstdint>

#include "core/flows/vector_isa.h"  // MESHSMOOTH_WIDE_LANES

namespace meshsmooth::flows {

// Two doubles in one SSE2 register (GCC vector extension): U1 takes two ring neighbours at a
// time. SSE2 is the x86-64 baseline, so every build computes the same bits.
using Lanes = double __attribute__((vector_size(16)));

// W doubles, one per vertex, for the cotangent kernel below (W = 1 is a plain double). Only
// lane-wise IEEE operations are used on them, so every lane computes the bits a plain double
// computation of the same vertex would: results do not depend on W.
template <int W>
struct VertexLanesOf;
template <>
struct VertexLanesOf<1> {
  using type = double;
};
template <>
struct VertexLanesOf<2> {
  typedef double type __attribute__((vector_size(16)));
};
template <>
struct VertexLanesOf<4> {
  typedef double type __attribute__((vector_size(32)));
};
template <>
struct VertexLanesOf<8> {
  typedef double type __attribute__((vector_size(64)));
};

// Square roots of the lanes. Builtins, not <immintrin.h>: its always_inline wrappers refuse to
// inline into these templates, which get their instruction set only once inlined into
// RunWithIsa's entry points.
inline double LaneSqrt(double x) { return std::sqrt(x); }
__attribute__((always_inline)) inline VertexLanesOf<2>::type LaneSqrt(VertexLanesOf<2>::type x) {
  return __builtin_ia32_sqrtpd(x);
}
#if MESHSMOOTH_WIDE_LANES
__attribute__((always_inline)) inline VertexLanesOf<4>::type LaneSqrt(VertexLanesOf<4>::type x) {
  return __builtin_ia32_sqrtpd256(x);
}
__attribute__((always_inline)) inline VertexLanesOf<8>::type LaneSqrt(VertexLanesOf<8>::type x) {
  return __builtin_ia32_sqrtpd512_mask(x, x, static_cast<unsigned char>(0xff), 4 /* current rounding */);
}
#endif

// True when a[l] < b[l] in some lane: one compare and one branch, whatever W (a select on
// the comparison would be lowered to a branch per lane, see MeanCurvatureLanes).
inline bool AnyLaneLess(double a, double b) { return a < b; }
__attribute__((always_inline)) inline bool AnyLaneLess(VertexLanesOf<2>::type a, VertexLanesOf<2>::type b) {
  return __builtin_ia32_movmskpd(__builtin_ia32_cmpltpd(a, b)) != 0;
}
#if MESHSMOOTH_WIDE_LANES
__attribute__((always_inline)) inline bool AnyLaneLess(VertexLanesOf<4>::type a, VertexLanesOf<4>::type b) {
  return __builtin_ia32_movmskpd256(__builtin_ia32_cmppd256(a, b, 1 /* _CMP_LT_OS */)) != 0;
}
__attribute__((always_inline)) inline bool AnyLaneLess(VertexLanesOf<8>::type a, VertexLanesOf<8>::type b) {
  return __builtin_ia32_cmppd512_mask(a, b, 1 /* _CMP_LT_OS */, static_cast<unsigned char>(0xff),
                                      4 /* current rounding */) != 0;
}
#endif

// a < b ? a : b and b < a ? a : b lane by lane (NaN in a gives b), as one instruction: GCC
// turns only some of these selects into minpd/maxpd.
inline double LaneMin(double a, double b) { return a < b ? a : b; }
inline double LaneMax(double a, double b) { return b < a ? a : b; }
__attribute__((always_inline)) inline VertexLanesOf<2>::type LaneMin(VertexLanesOf<2>::type a,
                                                                     VertexLanesOf<2>::type b) {
  return __builtin_ia32_minpd(a, b);
}
__attribute__((always_inline)) inline VertexLanesOf<2>::type LaneMax(VertexLanesOf<2>::type a,
                                                                     VertexLanesOf<2>::type b) {
  return __builtin_ia32_maxpd(a, b);
}
#if MESHSMOOTH_WIDE_LANES
__attribute__((always_inline)) inline VertexLanesOf<4>::type LaneMin(VertexLanesOf<4>::type a,
                                                                     VertexLanesOf<4>::type b) {
  return __builtin_ia32_minpd256(a, b);
}
__attribute__((always_inline)) inline VertexLanesOf<4>::type LaneMax(VertexLanesOf<4>::type a,
                                                                     VertexLanesOf<4>::type b) {
  return __builtin_ia32_maxpd256(a, b);
}
__attribute__((always_inline)) inline VertexLanesOf<8>::type LaneMin(VertexLanesOf<8>::type a,
                                                                     VertexLanesOf<8>::type b) {
  return __builtin_ia32_minpd512_mask(a, b, a, static_cast<unsigned char>(0xff), 4 /* current rounding */);
}
__attribute__((always_inline)) inline VertexLanesOf<8>::type LaneMax(VertexLanesOf<8>::type a,
                                                                     VertexLanesOf<8>::type b) {
  return __builtin_ia32_maxpd512_mask(a, b, a, static_cast<unsigned char>(0xff), 4 /* current rounding */);
}
#endif

// W int32 lanes beside them: vertex and ring indices.
template <int W>
struct IndexLanesOf;
template <>
struct IndexLanesOf<1> {
  using type = int32_t;
};
template <>
struct IndexLanesOf<2> {
  typedef int32_t type __attribute__((vector_size(8)));
};
template <>
struct IndexLanesOf<4> {
  typedef int32_t type __attribute__((vector_size(16)));
};
template <>
struct IndexLanesOf<8> {
  typedef int32_t type __attribute__((vector_size(32)));
};

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
#if MESHSMOOTH_WIDE_LANES
  } else if constexpr (W == 4) {
    return __builtin_ia32_gathersiv4si(fallback, base, index, live, 4);
  } else {
    return __builtin_ia32_gathersiv8si(fallback, base, index, live, 4);
#endif
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
#if MESHSMOOTH_WIDE_LANES
  } else if constexpr (W == 4) {
    return __builtin_ia32_gathersiv4df(V{}, base, index, V{} == V{}, 8);
  } else {
    return __builtin_ia32_gathersiv8df(V{}, base, index, static_cast<unsigned char>(0xff), 8);
#endif
  }
}

// The x, y and z of positions index3[l] / 3, lane by lane. With 8 lanes, eight masked loads of
// one position each (3 doubles; masked-off elements never fault past the array's end)
// transposed by shuffles instead of three gathers. The same values either way.
template <int W>
__attribute__((always_inline)) inline void GatherXyzLanes(const double* base,
                                                          const typename IndexLanesOf<W>::type& index3,
                                                          typename VertexLanesOf<W>::type& x,
                                                          typename VertexLanesOf<W>::type& y,
                                                          typename VertexLanesOf<W>::type& z) {
#if MESHSMOOTH_WIDE_LANES
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
  } else
#endif
  {
    x = GatherLanes<W>(base, index3), y = GatherLanes<W>(base + 1, index3), z = GatherLanes<W>(base + 2, index3);
  }
}

}  // namespace meshsmooth::flows
