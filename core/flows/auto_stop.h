// Automatic stopping (FlowParams::iterations == kAutoIterations): the run keeps the iteration
// whose estimated error to the noise-free surface is least. docs/quality-method.md and docs/decisions.md have the
// figures that chose the constants.
//
// Before the run, EstimateNoise() (core/measure/noise.h) reads the input's noise. Part of that reading is
// the estimator's own misfit on clean, coarse meshes (up to ~0.04 h on the benchmark's clean
// scans): it is removed in quadrature. Below kNoNoiseH there is nothing to remove and the run
// does no iteration: a clean mesh comes back as it went in; so does a mesh on which too few
// vertices allow an estimate (a fan whose rim sees one circle, a strip one triangle wide), and
// a mesh whose vertices lie almost all on creases (a CAD tessellation of slivers, whose fits span
// its creases: noise.h).
//
// Otherwise the error of every iteration is estimated with Stein's unbiased risk estimate
// (SURE; Stein 1981), in its Monte-Carlo form for any denoiser (Ramani, Blu, Unser 2008). With y
// the input's offsets along its normals N, noise of deviation sigma in them, and f_k(y) the
// offsets after k iterations, E|f_k(y) - x|^2 = E[ |f_k(y) - y|^2 - n sigma^2 + 2 sigma^2 div f_k(y) ],
// and the divergence is div f_k ~ b . (f_k(y + eps b) - f_k(y)) / eps for a random sign vector
// b: a probe copy of the input, moved by eps b along N, runs the same flow beside the real one.
// Both the fidelity term and the divergence are summed over the free interior vertices (every
// k-th one of a large mesh). The run keeps a copy of the best iteration so far and stops once
// the estimate has not improved for kPatience iterations and half as many as the best one took
// (the minimum is behind it: "noise_removed"), when it improves by less than kConvergedShare of
// sigma^2 a vertex over that stretch ("converged"), or after the cap; it returns the best one.
// Unlike the discrepancy principle (stop once the vertices moved as far as the noise), this
// needs no constant per flow: a feature-preserving flow that removes the noise without moving
// the vertices as far stops at its own best count. It costs a second run of the flow.
//
// sigma is the estimate's root mean square (NoiseEstimate::deviation_h), not its robust scale:
// SURE needs the variance, and the robust scale reads noise whose distribution is more peaked
// than a Gaussian's (noise in random directions) low, which makes the run stop far too early.
//
// Noise folds thin triangles over, and a run can leave some folded: RepairFolds() then takes the
// free interior vertices of edges whose two faces face nearly opposite ways (normals more than
// kFoldAngleDeg apart: a fold, not a crease) or of fans with a face turned against their ring,
// slides those of the second kind across the fan within the ring's plane to where the fan unfolds
// (kUnfoldHeight, kUnfoldSlideH), moves the others (and those that cannot unfold so) half-way to
// their ring's centroid, and moves rim vertices that slid across a face of theirs along their loop
// (kRimNeedleAngleDeg), a few rounds at most, no vertex further than kFoldRepairReachH h in all (a
// sliding one: along its ring's normal; kUnfoldSlideH h across it). Last, every flow with a step
// loses some volume: on a closed mesh the run gives the input's enclosed volume back by moving its
// free vertices along their normals by a common distance (KeepVolume): the shrinkage is a bias of
// the flow, not noise.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <vector>

#include "core/flows/flow.h"
#include "core/flows/job_policy.h"
#include "core/measure/noise.h"

namespace meshsmooth::flows {

// The estimator's misfit on clean meshes, removed in quadrature (in h).
inline constexpr double kEstimatorFloorH = 0.04;
// Below this much noise (in h, after the floor) the run does nothing.
inline constexpr double kNoNoiseH = 0.02;
// Nor when the noise estimate with the fits' misfit of detail taken out
// (NoiseEstimate::detail_free_h) is below this (in h). On the quality benchmark's inputs the
// clean meshes read 0.000-0.020 h there (nefertiti 0.020; `dragon-8k`, whose detail one or two
// edges wide reads 0.074 h of noise, 0.000), the noisy ones (0.1 h and more, along the normals or
// in random directions) 0.042 h and more (`dragon-8k` at random 0.1 h; the smooth meshes there
// 0.046-0.052); docs/quality-method.md.
inline constexpr double kDetailOnlyH = 0.03;
// ... unless the noise turns the faces visibly (TurnsFacesVisibly, job_policy.h).
// The run stops when the estimated error has not improved for this many iterations, and for
// half as many as the best iteration took.
inline constexpr int kPatience = 8;
// ... or when over that stretch (the last half of the run) it improved by less than this
// share of sigma^2 a vertex: a smooth closed shape keeps improving for hundreds of iterations
// (the noisy icosphere: 1000 at 1e-3, 4 s for 2,562 vertices; 393 and 0.3 s at 1e-2), by
// amounts far below the noise.
inline constexpr double kConvergedShare = 1e-2;
// SURE under an underestimated sigma stops far too early (the torus with noise in random
// directions: 1.9 times the error of the flow's best count), under an overestimated one a
// little late; the deviation is taken this much high. Over the benchmark's 37 cases the chosen
// count's error is then within 1.13 times the best count's for bilateral_normal (1.05 for
// bilaplacian), mean 1.03 (1.01); docs/quality.md.
inline constexpr double kRiskSigmaMargin = 1.1;
// The sigma the risk estimate works with, in h: the noise's deviation taken kRiskSigmaMargin high.
inline double RiskSigmaH(const NoiseEstimate& noise) { return kRiskSigmaMargin * noise.deviation_h; }
// The probe copy is moved by +-kProbeStep sigma along the normals: small enough for the
// finite difference to be a derivative, large enough to stay far above rounding.
inline constexpr double kProbeStep = 0.05;
// Two faces across an edge whose normals are further apart than this are folded.
inline constexpr double kFoldAngleDeg = 120.0;

// Walks the fan of interior vertex v (positions `pos`) and calls on_fold(w) for each ring entry
// w whose edge (v, w) is folded: its two faces' normals more than kFoldAngleDeg apart
// (`cos_fold` = FoldCosine()). Stops, returning true, as soon as on_fold returns true.
inline double FoldCosine() { return std::cos(kFoldAngleDeg * std::numbers::pi / 180.0); }
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
// The estimated error is summed over at most about this many vertices (every k-th of a larger
// mesh): over 50,000 of them it is within ~0.5% of the whole mesh's, at a fraction of the cost
// of an iteration.
inline constexpr int32_t kMaxMeasured = 50000;
// A run with a rival (SetRival) gives up once its estimate, less kRivalReach times what it would
// still fall if its decrease over the last kRivalWindow iterations kept shrinking at the rate
// it shrank from the kRivalWindow before, stays above the rival's: a candidate that loses stops
// after a few iterations instead of running to its own minimum (docs/decisions.md, "The default
// job chooses on a sample"). A shorter window reads the estimate's own jitter as a slowdown.
inline constexpr int kRivalWindow = 4;
inline constexpr double kRivalReach = 2.0;
// A default job whose noise estimate finds more than this share of its fits outliers
// (NoiseEstimate::outlier_share: up to 1.75% on the benchmark's clean and Gaussian-noisy meshes,
// about 9% with a tenth of the vertices thrown 1-3 h) first moves the outliers onto their fitted
// surfaces (RemoveOutliers, at most kOutlierRounds rounds) and reads the noise again: the
// estimate's Gaussian model, on which the risk estimate rests, does not hold for thrown vertices,
// and the run stopped after one iteration with them (docs/decisions.md, "Outliers").
inline constexpr double kImpulsiveShare = 0.04;
inline constexpr int kOutlierRounds = 3;
// The default job (every automatic run: choice.h) does not take a candidate whose result has
// more area than its input, or more folded edges (kFoldAngleDeg) than this share of the faces
// over the input's: noise adds both, and a run that adds them made the input worse, whatever
// its risk estimate says. The estimate reads offsets along the normals; on a CAD part of slivers
// with noise, the runs that lower it move vertices along the slivers and turn their faces
// (the sliver shaft at 0.1 h, read with the narrow noise estimate alone: area 1.11 times the
// input's, 119 -> 348 folded edges, normal error 1.62 times the input's; the detail-free
// estimate now returns that input first). When no candidate is left the input comes back
// ("no_gain"). On the benchmark's other inputs every result has at most 0.994 times its input's
// area and fewer folded edges (docs/decisions.md, "A run that leaves its input rougher").
inline constexpr double kNoGainFoldShare = 2e-4;
// A rim vertex the run moved (a bilateral_normal run's) is folded when one of its faces points
// against its open fan's normal or has an angle above this at it: the vertex has slid onto or
// across the face's far edge. The repair moves it half-way to the midpoint of its neighbours
// along the loop. On the perforated sphere (431 holes) at sigma = 0.7 h the default job's run
// left 36 such faces, all needles of a rim vertex, flipped against the clean surface; the
// repair leaves none (docs/decisions.md, "Fold repair, within 0.2 h").
inline constexpr double kRimNeedleAngleDeg = 160.0;
// At most this many rounds of fold repair.
inline constexpr int kFoldRepairRounds = 20;
// The fold repair moves no vertex further than this (in h) from where the run left it. A fold
// the noise made on a needle comes undone within it; the faces of a feature thinner than the
// noise (the turbine's narrow strips between right-angled creases) also meet at more than
// kFoldAngleDeg after a run, and pulling their vertices on to their rings' centroids without a
// bound flattens the feature: the turbine's default job at sigma = 0.1 / 0.2 / 0.3 h ends at RMS
// 0.061 / 0.092 / 0.123 h with the repair unbounded, 0.052 / 0.081 / 0.113 h with this bound,
// 0.051 / 0.079 / 0.112 h without the repair; the dragon keeps most of what the repair gains
// there (docs/decisions.md, "Fold repair, within 0.2 h").
inline constexpr double kFoldRepairReachH = 0.2;
// A folded interior vertex whose fan turns a face against its ring (FanFolds: folded within the
// ring's plane, which does not depend on where the vertex is) slides across its fan instead:
// to the nearest point where every face of the fan, projected on that plane, has a height of
// at least kUnfoldHeight times its far edge, found by projecting onto one face's condition
// after another (kUnfoldSweeps sweeps over the fan). A fold the noise made in a surface that is
// flat at the scale of a ring is a vertex pushed across its ring; the centroid step undoes it
// only within its bound, and moves the vertex along the normal too. The slide moves no vertex
// further than kUnfoldSlideH h within the plane. Where no such point exists, and where only
// edges fold (out of the plane), the centroid step above is taken. A vertex also counts as
// folded when its fan turns a face against its ring with no edge folded beyond kFoldAngleDeg.
// Over the benchmark's default rows at sigma 0.1-0.3 h, in random directions and impulsive,
// the repair leaves 9% fewer flipped faces (marching-tetrahedra cylinder 0.1 h 22 -> 11,
// turbine 0.2 h 110 -> 93, the Stanford dragon at random 0.3 h 2,034 -> 1,573) with RMS
// distance and normal error within 0.6% of the centroid step's (docs/decisions.md, "Fold
// repair, within 0.2 h").
inline constexpr double kUnfoldHeight = 0.05;
inline constexpr int kUnfoldSweeps = 30;
inline constexpr double kUnfoldSlideH = 1.0;

class AutoStop {
 public:
  // Reads the noise of `mesh` (the run's input; the positions of the measured vertices are
  // kept as the reference),
  // or takes `noise` when it is not null. `role` is the run's vertex roles
  // (core/flows/flow_kernel.h), one per vertex; `measured` (null: all) the vertices the
  // estimate measures, among the free interior ones, and with `rims` the boundary ones too,
  // whatever their role (a fixed rim keeps its noise: the estimate counts it).
  AutoStop(const Mesh& mesh, const Topology& topo, const uint8_t* role, double h, int threads,
           const NoiseEstimate* noise, const std::vector<uint8_t>* measured, bool rims = false);

  // True when the input has no noise to remove: the run does no iteration.
  bool nothing_to_do() const { return !estimated_ || report_.noise_to_remove_h < kNoNoiseH; }
  // Why the run does nothing when nothing_to_do().
  StopReason idle_reason() const { return estimated_ ? StopReason::kNoNoise : StopReason::kNoEstimate; }

  // The probe's input: `start` (the run's input, as given to the constructor) moved by
  // +-kProbeStep sigma along its normals. Called once, before the first After().
  std::vector<Vec3> ProbeStart(const std::vector<Vec3>& start);

  // After accepted iteration `it` with positions `pos` (the probe's: `probe`): the reason to
  // stop now, if any. improved() tells whether `pos` is the best iteration so far.
  std::optional<StopReason> After(int it, const Vec3* pos, const Vec3* probe);
  bool improved() const { return improved_; }
  // The report for the positions `pos` the run returns: those of the best iteration After()
  // found, or reached without After() (a count chosen beforehand). After() leaves the
  // displacement to this (a pass over the rings, once per run rather than once per iteration).
  AutoStopReport Measure(const Vec3* pos) const {
    AutoStopReport r = report_;
    r.displacement_h = RmsNormalDisplacement(pos) / h_;
    return r;
  }
  int best_iteration() const { return best_it_; }

  // Moves the folded free interior vertices of `pos` whose fans turn a face against their ring
  // across the fan where that unfolds it (SlideToUnfold), the others half-way to their ring's
  // centroid, and the folded rim vertices the run moved (RimFolded) half-way to the midpoint of
  // their loop neighbours, until none is folded (at most kFoldRepairRounds rounds; no vertex
  // further than kFoldRepairReachH h in all, or kUnfoldSlideH h within its ring's plane when it
  // slid). Returns the folded vertices left.
  int64_t RepairFolds(Vec3* pos) const;

  // On a closed mesh (every vertex in use interior), moves the free vertices of `pos` along
  // their normals by the common distance that restores the input's enclosed volume.
  void KeepVolume(Vec3* pos) const;

  const AutoStopReport& report() const { return report_; }

  // After() stops the run ("noise_removed") once its estimate cannot reach `risk_h2` (a
  // rival's AutoStopReport::risk_h2 on the same input): the run then loses to the rival.
  void SetRival(double risk_h2) { rival_ = risk_h2 * h_ * h_ + sigma_ * sigma_; }

 private:
  double RmsNormalDisplacement(const Vec3* pos) const;
  // SURE of `pos` less its constant n sigma^2, a vertex, over the measured vertices.
  double Risk(const Vec3* pos, const Vec3* probe) const;
  // The probe's sign at vertex v: +1 or -1, from a hash of v (the same for any thread count).
  static double Sign(int32_t v);
  // Whether vertex `v` is folded, and how: kFanFolded for a free interior vertex with a face of
  // its fan turned against its ring's orientation (FanFolds: RepairFolds slides it), kFolded for
  // one with two consecutive faces of its ring folded, or for a boundary vertex the run moved
  // (kCurve) that is folded (RimFolded).
  enum Fold : uint8_t { kNotFolded = 0, kFolded, kFanFolded };
  Fold Folded(const Vec3* pos, int32_t v) const;
  // For a free interior vertex v: into `to`, the point nearest to pos[v] in the plane through
  // it normal to `normal` (its ring's unit normal) where each face of its fan, projected on
  // that plane, has a height of at least kUnfoldHeight times its far edge (within half of it:
  // the projection overshoots to the full height). False when kUnfoldSweeps sweeps do not
  // reach one (no such point, or none near).
  bool SlideToUnfold(const Vec3* pos, int32_t v, const Vec3& normal, Vec3& to) const;
  // True when a face of rim vertex v's open fan points against the fan's normal (FanFolds, as
  // the outlier removal's unfolding reads it), or has an angle above kRimNeedleAngleDeg at v (v
  // lies on the far edge of a needle).
  bool RimFolded(const Vec3* pos, int32_t v) const;
  // Enclosed volume of a closed mesh from the vertices' rings.
  double Volume(const Vec3* pos) const;

  const Topology& topo_;
  const uint8_t* role_;
  double h_;
  int threads_;
  std::vector<Vec3> start_;  // the input's position of every stride_-th vertex
  bool estimated_ = false;   // the noise estimate is reliable (core/measure/noise.h)
  int32_t stride_ = 1;       // every stride_-th vertex is measured
  int64_t counted_ = 0;      // free interior vertices measured
  double cos_fold_ = FoldCosine();
  double cos_rim_needle_ = std::cos(kRimNeedleAngleDeg * std::numbers::pi / 180.0);
  bool closed_ = true;  // every vertex in use is interior
  double start_volume_ = 0.0;
  double sigma_ = 0.0;  // the noise's deviation, in mesh units
  // The unit normal of the ring at v in the input's positions `pos`, or none where the ring
  // has no area.
  std::optional<Vec3> UnitNormal(const Vec3* pos, int32_t v) const;

  std::vector<uint8_t> has_normal_;  // per vertex: one of the measured vertices, with a normal
  std::vector<Vec3> normal_;         // ProbeStart's: their unit normals, else zero
  double best_risk_ = 0.0;
  int best_it_ = 0;
  bool improved_ = false;
  std::vector<double> risks_;    // of every iteration so far
  std::optional<double> rival_;  // SetRival's, in Risk()'s units
  AutoStopReport report_;
};

}  // namespace meshsmooth::flows
