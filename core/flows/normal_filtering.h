// Internal to core/flows: what the normal-filtering flows (bilateral_normal.cc,
// guided_normal.cc) share. One round (one iteration of the job) filters the face normals
// `normal_iterations` times (the flow's FilterOnce), then moves the vertices so that the faces
// fit the filtered normals, `vertex_iterations` times (one pass each):
//   x_v += step * sum_{f in F(v)} A_f n_f (n_f . (c_f - x_v)) / sum_{f in F(v)} A_f
// the orthogonal-projection update of Sun et al. (2007) used by Zheng et al. (2011) and Zhang
// et al. (2015), with area weights A_f (the round's areas) and c_f the centroid of face f in the
// pass's positions (normal_vertex_update.cc). Two guards keep faces from folding, which the
// projection alone neither prevents nor repairs on scans with needles: a face whose normal
// opposes its neighbourhood's enters the filter with the neighbourhood's normal, and a pass
// never turns a face against its filtered normal (a vertex whose move would is moved half as
// far, then not at all); the vertices of a face that is turned against it also relax
// tangentially, which unfolds it. docs/normal-filtering.md gives the equations and the choices
// made here.
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

#include "core/flows/flow_kernel.h"
#include "core/flows/lanes.h"
#include "core/flows/vector_isa.h"

namespace meshsmooth::flows {

// The checks of the normal-filtering flows' rows (flow_table.h): the filter's counts and sigmas
// in range; InvalidArgument naming the parameter.
absl::Status ValidateNormalFilter(const FlowParams& p, double step);

// The faces of a run and their neighbourhoods, built once per run.
struct FaceGraph {
  // The usable faces (Topology::faces) in Morton order of their centroids: neighbouring faces
  // sit close in memory, and the order (so every sum) does not depend on how the vertices are
  // numbered.
  std::vector<Triangle> faces;
  // The faces around each vertex (indices into `faces`), ascending, CSR.
  std::vector<int32_t> vertex_offsets, vertex_faces;
  // The faces sharing a vertex with each face, the face itself included, ascending, CSR.
  std::vector<int32_t> offsets, neighbours;
  // The face across each edge (v0 v1, v1 v2, v2 v0), or -1 on a boundary or non-manifold edge.
  std::vector<std::array<int32_t, 3>> across;
  // Mean distance between the centroids of faces that share an edge, on the input (sigma_s
  // is relative to it); 0 when no two faces share an edge.
  double mean_centroid_distance = 0.0;
};

FaceGraph BuildFaceGraph(const Mesh& mesh, const Topology& topo, int threads);

inline Vec3 Centroid(const Vec3* pos, const Triangle& t) { return (pos[t[0]] + pos[t[1]] + pos[t[2]]) * (1.0 / 3.0); }
// Twice the area times the unit normal of triangle t.
inline Vec3 FaceCross(const Vec3* pos, const Triangle& t) {
  return Cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]);
}

// exp(-x) lane by lane for x >= 0, W >= 2: x / ln 2 = k + r with k the nearest integer, exp(-r ln 2)
// from its Taylor polynomial of degree 7 (|r ln 2| <= 0.35: relative error below 1e-8), times
// 2^-k from its exponent bits; 0 from x = 40 on (exp(-40) < 5e-18) and for NaN. Only lane-wise
// IEEE operations (no FMA: core is built with -ffp-contract=off), so any W gives the same bits.
// libm's exp is a call per weight; the filters compute one weight per neighbour entry.
template <int W>
__attribute__((always_inline)) inline typename VertexLanesOf<W>::type NegExpLanes(typename VertexLanesOf<W>::type x) {
  using V = typename VertexLanesOf<W>::type;
  using I = typename IndexLanesOf<W>::type;
  typedef int64_t L __attribute__((vector_size(8 * W)));
  const V zero = V{} + 0.0;
  const V t = x < 40.0 ? x * 1.4426950408889634 : zero;  // x / ln 2, below 58
  const I k = __builtin_convertvector(t + 0.5, I);       // t >= 0: truncation rounds
  const V g = (t - __builtin_convertvector(k, V)) * 0.6931471805599453;
  // Estrin's scheme: a shorter chain of dependent operations than Horner's.
  const V g2 = g * g;
  const V g4 = g2 * g2;
  const V p01 = 1.0 - g, p23 = 0.5 - g * (1.0 / 6.0), p45 = 1.0 / 24.0 - g * (1.0 / 120.0),
          p67 = 1.0 / 720.0 - g * (1.0 / 5040.0);
  const V p = (p01 + g2 * p23) + g4 * (p45 + g2 * p67);
  const L bits = (__builtin_convertvector(1023 - k, L)) << 52;  // 2^-k
  V scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return x < 40.0 ? p * scale : zero;
}

// A face's orientation against its filtered normal in a pass's positions.
enum FaceState : uint8_t {
  kNoNormal = 0,  // no filtered normal (no area at the round's start)
  kAgrees = 1,    // its normal . the filtered normal > 0: a pass keeps it so
  kOpposes = 2,   // folded: its vertices relax tangentially
};

// The cosine between a face with cross product `cross` and the filtered normal n; -2 (below
// any cosine) for a face that has collapsed.
inline double CosineTo(const Vec3& cross, const Vec3& n) {
  const double len = Norm(cross);
  return len > 0.0 ? Dot(cross, n) / len : -2.0;
}

// A normal-filtering flow: the rounds, the face geometry and the vertex update. A flow derives
// from it and implements FilterOnce.
class NormalFilterKernel : public FlowKernel {
 public:
  explicit NormalFilterKernel(const NormalFilterParams& p) : p_(p) {}
  int passes() const override { return p_.vertex_iterations; }
  void Bind(const Mesh& mesh, const Topology& topo, int threads) override;
  // The first pass of a round filters the normals of the round's input; every pass computes
  // the vertex update (with its guards) into target_.
  void Prepare(const StepContext& c, const Vec3* cur, int32_t n, int threads) override;
  // The pass's moves, computed by Prepare: copies them and measures them.
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override;

 protected:
  // One pass of the filter: reads normal_ (unit, or zero for a face without area) and writes
  // the filtered normals to `out`, face by face, on `threads_` threads.
  virtual void FilterOnce(std::vector<Vec3>& out) = 0;

  // Runs fn(face) over every face on threads_ threads, in fixed blocks.
  template <typename Fn>
  void ForFaces(Fn&& fn) const {
    ForBlocks(static_cast<int32_t>(graph_.faces.size()), threads_, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t f = begin; f < end; ++f) fn(f);
    });
  }

  // Into `out`, each face's bilateral sum of its neighbours' normals (normal_) with range
  // weights on |g_i - g_j| (g = normal_ for the bilateral filter, or guidance normals),
  // normalised; face i's own normal when the sum vanishes or it has no area. On threads_
  // threads, W faces at a time in lanes (isa_). In the round's last filter pass, each face is
  // also fitted to the round's positions with its new normal (FitFace).
  void Filter(const std::vector<Vec3>& g, std::vector<Vec3>& out);

  NormalFilterParams p_;
  int threads_ = 1;
  VectorIsa isa_ = VectorIsa::kSse2;  // the run's (StepContext::isa)
  FaceGraph graph_;
  std::vector<Vec3> normal_;                                // per face: unit, or zero without area
  std::vector<double> area_;                                // per face
  double inv_two_sigma_s2_ = 0.0, inv_two_sigma_r2_ = 0.0;  // 1 / (2 sigma^2)
  std::vector<Vec3> centroid_, filtered_;                   // buffers kept from round to round
  std::vector<Vec3> cross_;                                 // per face: its cross product in the round's positions
  std::vector<Vec3> weighted_;                              // per face: its area times its unit normal

 private:
  // Per vertex, for the round: sum_f A_f n_f n_f^T (symmetric) and sum_f A_f over its faces
  // with a normal, so that the update's sum is sum_f q_f - M x_v.
  struct VertexPlanes {
    double xx, xy, xz, yy, yz, zz, weight;
  };

  // Normals, areas, centroids and cross products of the positions `pos`; a face whose normal
  // opposes the area-weighted normal of its neighbours takes theirs.
  void ComputeGeometry(const Vec3* pos);
  // Face f with cross product `cross` and centroid `centroid` against its filtered normal n:
  // its FaceState, its cosine when it opposes n or `folded_now` (into next_state_ and
  // next_cosine_ when `next`, else state_ and cosine_) and its term q_f; returns its cosine
  // when computed, else 1.
  __attribute__((always_inline)) double FitFace(int32_t f, const Vec3& n, const Vec3& cross, const Vec3& centroid,
                                                bool next, bool folded_now) {
    const double a = area_[f];
    const uint8_t state = a == 0.0 ? kNoNormal : Dot(cross, n) > 0.0 ? kAgrees : kOpposes;
    (next ? next_state_ : state_)[f] = state;
    q_[f] = state == kNoNormal ? Vec3{} : n * (a * Dot(n, centroid));
    // A cosine is read only while its face is folded (now or in the next pass): the square root
    // is skipped for the others, whose entry is not written.
    if (state != kOpposes && !folded_now) return 1.0;
    const double cosine = CosineTo(cross, n);
    (next ? next_cosine_ : cosine_)[f] = cosine;
    return cosine;
  }
  // Every face fitted to the positions `pos` (state_, cosine_, q_).
  void FitFaces(const Vec3* pos);
  // One pass of the vertex update from `cur` into target_ (at the round's start, the vertices'
  // planes_ too); returns false (and leaves target_ unfinished) when `check_start` and `cur`
  // is not the positions the faces were fitted to (target_).
  bool UpdateVertices(const StepContext& c, const Vec3* cur, int32_t n, int threads, bool round_start,
                      bool check_start);
  // Damps the moves in target_ until no face turns against its filtered normal, and leaves
  // state_, cosine_ and (with `terms`) q_ for the positions target_ holds then.
  void GuardOrientation(const Vec3* cur, int32_t n, int threads, bool terms);

  int pass_ = 0;                // passes prepared so far
  bool fit_ = false;            // Filter fits the faces (the round's last filter pass)
  std::vector<Vec3> target_;    // per vertex: the pass's result
  std::vector<uint8_t> state_;  // per face: FaceState in the pass's positions
  std::vector<double> cosine_;  // per face: between it and its filtered normal, ditto
  std::vector<uint8_t> next_state_;
  std::vector<double> next_cosine_;
  std::vector<Vec3> q_;               // per face: A_f (n_f . c_f) n_f in the pass's positions; zero without normal
  std::vector<VertexPlanes> planes_;  // per vertex, for the round
  std::vector<std::vector<int32_t>> turned_;  // per block of faces: those the guard's first round found turned
  std::vector<uint8_t> damping_;              // per vertex: 0 full move, 1 half, 2 none
  std::vector<int64_t> capped_;               // per block of kBlock vertices: moves capped at max_step_sq
  std::vector<uint8_t> moved_on_;             // per block of kBlock vertices: `cur` was not target_
  std::vector<int32_t> stamp_;                // per vertex: the guard round that last listed it
  std::vector<int32_t> refit_stamp_;          // per face: the pass whose guard last listed it to fit again
  std::vector<uint8_t> damped_;               // per vertex the guard looks at: a face of it turns
  int32_t round_ = 0;                         // guard rounds so far
};

}  // namespace meshsmooth::flows
