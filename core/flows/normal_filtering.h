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
#include <vector>

#include "core/flows/flow_kernel.h"

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
  // Per face: the entry of vertex_faces that lists it for each of its corners.
  std::vector<std::array<int32_t, 3>> corner_entry;
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

// exp(-x) for x >= 0 from a table with linear interpolation (relative error below 1e-6; 0 from
// x = 40 on, where exp(-x) < 5e-18): the filters' weights take most of their time with libm's
// exp, and a weight needs no more digits than that.
namespace internal {
inline constexpr int kNegExpSize = 1 << 14;
inline constexpr double kNegExpScale = kNegExpSize / 40.0;
extern const double* const kNegExpValues;  // exp(-i / kNegExpScale), i = 0 .. kNegExpSize + 1
}  // namespace internal
inline double NegExp(double x) {
  const double s = x * internal::kNegExpScale;
  if (!(s < internal::kNegExpSize)) return 0.0;  // NaN too
  const int i = static_cast<int>(s);
  const double* v = internal::kNegExpValues;
  return v[i] + (v[i + 1] - v[i]) * (s - i);
}

// A normal-filtering flow: the rounds, the face geometry and the vertex update. A flow derives
// from it and implements FilterOnce.
class NormalFilterKernel : public FlowKernel {
 public:
  // A face's term of the vertex update at one of its corners v.
  struct Term {
    Vec3 move;    // A_f n_f (n_f . (c_f - x_v)); zero for a face without normal
    double area;  // A_f, negative when the face opposes its filtered normal; 0 without normal
  };

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

  // The bilateral sum of face i's neighbours' normals with range weights on |g_i - g_j| (g =
  // normal_ for the bilateral filter, or guidance normals), normalised; face i's own normal
  // when the sum vanishes.
  Vec3 FilteredNormal(int32_t i, const std::vector<Vec3>& g) const;

  NormalFilterParams p_;
  int threads_ = 1;
  FaceGraph graph_;
  std::vector<Vec3> normal_;  // per face: unit, or zero without area
  std::vector<double> area_;  // per face
  // Per neighbour entry j of face i: A_j exp(-|c_i - c_j|^2 / (2 sigma_s^2)); a float is as
  // precise as a weight needs and halves what the filter reads.
  std::vector<float> spatial_;
  double inv_two_sigma_r2_ = 0.0;
  std::vector<Vec3> raw_, centroid_, filtered_;  // buffers kept from round to round

 private:
  // Normals, areas and the spatial weights of the positions `pos`; a face whose normal
  // opposes the area-weighted normal of its neighbours takes theirs.
  void ComputeGeometry(const Vec3* pos);
  // Each face's orientation (FaceState) in the positions `pos`, and its terms of the next
  // vertex pass.
  void FitFaces(const Vec3* pos);
  // One pass of the vertex update from `cur` into target_; returns false (and leaves target_
  // unfinished) when `cur` is not the positions the terms in term_ were written for.
  bool UpdateVertices(const StepContext& c, const Vec3* cur, int32_t n, int threads, bool check_start);
  // Damps the moves in target_ until no face turns against its filtered normal, and leaves
  // state_ and cosine_ for the positions target_ holds then; with `terms`, the terms of the
  // next pass too.
  void GuardOrientation(const Vec3* cur, int32_t n, int threads, bool terms);

  int pass_ = 0;                // passes prepared so far
  std::vector<Vec3> target_;    // per vertex: the pass's result
  std::vector<uint8_t> state_;  // per face: FaceState in the pass's positions
  std::vector<double> cosine_;  // per face: between it and its filtered normal, ditto
  std::vector<uint8_t> next_state_;
  std::vector<double> next_cosine_;
  // The vertex update's terms, one per entry of graph_.vertex_faces (Term): written by the
  // face loops, summed by each vertex over its own contiguous entries, in ascending face order.
  std::vector<Term> term_;
  std::vector<std::vector<int32_t>> turned_;  // per block of faces: those the guard's first round found turned
  std::vector<uint8_t> damping_;              // per vertex: 0 full move, 1 half, 2 none
  std::vector<int64_t> capped_;               // per block of kBlock vertices: moves capped at max_step_sq
  std::vector<uint8_t> moved_on_;             // per block of kBlock vertices: `cur` was not target_
  std::vector<int32_t> stamp_;                // per vertex: the guard round that last listed it
  int32_t round_ = 0;                         // guard rounds so far
};

}  // namespace meshsmooth::flows
