// The default job's edits of the mesh, all here (policy.h has their numbers; docs/decisions.md,
// "Fold repair, within 0.2 h", "The volume given back", "A run that leaves its input rougher is
// not taken" and "Outliers", the figures): the fold repair and the volume after a run, the
// roughness test that refuses a run, and the outliers moved back before one.
//
// Noise folds thin triangles over, and a run can leave some folded. FoldRepair takes the free
// interior vertices of edges whose two faces face nearly opposite ways (normals more than
// fold_angle_deg apart: a fold, not a crease) or of fans with a face turned against their ring
// (FanFolds, core/measure/noise.h), slides those of the second kind across the fan within the
// ring's plane to where the fan unfolds (unfold_height, unfold_slide_h), moves the others (and
// those that cannot unfold so) half-way to their ring's centroid, and moves rim vertices the run
// moved that slid across a face of theirs (rim_needle_angle_deg) half-way to the midpoint of
// their loop neighbours, a few rounds at most, no vertex further than fold_repair_reach_h h in
// all (a sliding one: along its ring's normal; unfold_slide_h h across it). A fold the noise
// made on a needle comes undone within that reach; a feature thinner than the noise (narrow
// strips between right-angled creases) is not flattened.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "core/job/policy.h"
#include "core/mesh.h"
#include "core/topology.h"
#include "core/util/stop_token.h"
#include "core/vec3.h"

namespace meshsmooth::job {

// The cosine of `policy`'s fold_angle_deg.
inline double FoldCosine(const JobPolicy& policy) { return std::cos(policy.fold_angle_deg * std::numbers::pi / 180.0); }

// Walks the fan of interior vertex v (positions `pos`) and calls on_fold(w) for each ring entry
// w whose edge (v, w) is folded: its two faces' normals more than fold_angle_deg apart
// (`cos_fold` = FoldCosine(policy)). Stops, returning true, as soon as on_fold returns true.
template <typename OnFold>
bool ForFoldedEdges(const Vec3* pos, const Topology& topo, int32_t v, double cos_fold, OnFold on_fold) {
  const int32_t first = topo.ring_offsets[v], last = topo.ring_offsets[v + 1];
  const Vec3 p = pos[v];
  Vec3 prev = pos[topo.ring[last - 1]] - p;
  Vec3 before = Cross(pos[topo.ring[last - 2]] - p, prev);  // the face before edge (v, ring[last - 1])
  for (int32_t k = first; k < last; ++k) {
    const Vec3 cur = pos[topo.ring[k]] - p;
    const Vec3 after = Cross(prev, cur);  // `before` and `after` share edge (v, ring[k - 1])
    if (Dot(before, after) < cos_fold * Norm(before) * Norm(after) &&
        on_fold(topo.ring[k == first ? last - 1 : k - 1])) {
      return true;
    }
    before = after;
    prev = cur;
  }
  return false;
}

// The fold repair (above) of a run whose vertices have roles `role` (core/flows/flow_kernel.h).
class FoldRepair {
 public:
  FoldRepair(const Topology& topo, const uint8_t* role, double h, int threads, const JobPolicy& policy);
  // Repairs `pos` until no vertex is folded (at most fold_repair_rounds rounds); returns the
  // folded vertices left.
  int64_t Run(Vec3* pos) const;

 private:
  // Whether vertex `v` is folded, and how: kFanFolded for a free interior vertex with a face of
  // its fan turned against its ring's orientation (Run slides it), kFolded for one with two
  // consecutive faces of its ring folded, or for a boundary vertex the run moved (kCurve) that
  // is folded (RimFolded).
  enum Fold : uint8_t { kNotFolded = 0, kFolded, kFanFolded };
  Fold Folded(const Vec3* pos, int32_t v) const;
  // For a free interior vertex v: into `to`, the point nearest to pos[v] in the plane through
  // it normal to `normal` (its ring's unit normal) where each face of its fan, projected on
  // that plane, has a height of at least unfold_height times its far edge (within half of it:
  // the projection overshoots to the full height). False when unfold_sweeps sweeps do not reach
  // one (no such point, or none near).
  bool SlideToUnfold(const Vec3* pos, int32_t v, const Vec3& normal, Vec3& to) const;
  // True when a face of rim vertex v's open fan points against the fan's normal (FanFolds), or
  // has an angle above rim_needle_angle_deg at v (v lies on the far edge of a needle).
  bool RimFolded(const Vec3* pos, int32_t v) const;

  const Topology& topo_;
  const uint8_t* role_;
  double h_;
  int threads_;
  const JobPolicy& policy_;
  double cos_fold_, cos_rim_needle_;
};

// Enclosed volume of a closed mesh from its vertices' rings.
double EnclosedVolume(const Vec3* pos, const Topology& topo, int threads);

// Moves the free interior vertices of `pos` (roles `role`) along their normals by the common
// distance that gives a closed mesh back `volume`; leaves it when that is more than
// max_offset_h x h (a flow's shrinkage is less than h; enhancement's growth may be more).
void RestoreVolume(Vec3* pos, const Topology& topo, const uint8_t* role, double h, int threads, double volume,
                   double max_offset_h = 1.0);

// The area of the usable faces of `mesh` at positions `pos`: noise adds area, and a run that
// removes noise takes it away. The job does not take a run that leaves its input more area.
double SurfaceArea(const std::vector<Vec3>& pos, const Mesh& mesh, const Topology& topo);

// True when a face of v's fan turns against the fan's orientation (an interior vertex's: the
// vector area of its ring polygon, which does not depend on where the vertex is; a boundary
// vertex's: the sum of its open fan's faces).
bool FanFolds(const Vec3* pos, const Topology& topo, int32_t v);

// A vertex whose fan folds (FanFolds) goes to its ring's centroid (a boundary vertex to the
// midpoint of its two neighbours along the rim, so that a hole keeps its size); Jacobi rounds,
// at most `rounds`, until no fan folds. Vertices where `keep` is non-zero stay; `moved` is set
// where a vertex moved. Returns how many vertices moved that `moved` did not hold yet.
// Deterministic for any thread count; stops early once `stop` fires.
int64_t UnfoldFans(Mesh& mesh, const Topology& topo, int rounds, std::vector<uint8_t>& moved, int threads = 0,
                   const StopToken& stop = {}, const uint8_t* keep = nullptr);

// Puts vertices of `pos` back where `input` has them until `pos` has no more folded faces
// (core/measure/folded_faces.h) than `input`: each round, the vertices of every face folded in
// `pos` but not in `input` and of the faces across its edges (one of them moved, or the face
// would be as it was). At most max_rounds rounds, then every vertex goes back. Returns the
// vertices put back. What the default job does last when it is given strengths: a run pulls
// its vertices against the fixed ones at a region's edge.
int64_t KeepNoMoreFolds(Vec3* pos, const Vec3* input, const Mesh& mesh, const Topology& topo, int max_rounds = 64);

// Moves the outliers back (docs/decisions.md, "Outliers"): an interior vertex whose normalised
// residual (LocalFit::ResidualH, core/measure/noise.h) exceeds `threshold_h`, or a vertex without
// a fit (a boundary vertex, a ring too small) whose ring's median height (LocalFit::RingHeight)
// exceeds threshold_h h. Each goes along the normal of the plane through the inliers of its first
// and second rings to the median height of its first ring's inliers: the fit, pulled by the other
// outliers around, can reach far, and a thrown vertex's faces tilt its own normal. A round flags
// the outliers, then moves them all from the same positions; at most `rounds` rounds, until none
// is left (a thrown vertex pulls its neighbours' fits, so the first round can leave some). Then
// the folds the throws leave (UnfoldFans, `unfold_rounds` rounds at most). Vertices where `keep`
// (per vertex) is non-zero stay; `moved` (one entry per vertex) is set where a vertex moved.
// Deterministic for any thread count; stops early once `stop` fires. `fit`: the local fits'
// numbers (JobPolicy::noise).
void RemoveOutliers(Mesh& mesh, const Topology& topo, double h, double threshold_h, int rounds,
                    std::vector<uint8_t>& moved, int threads = 0, const StopToken& stop = {},
                    const uint8_t* keep = nullptr, int unfold_rounds = kPolicy.unfold_rounds,
                    const NoiseParams& fit = kPolicy.noise);

}  // namespace meshsmooth::job
