// Automatic stopping (FlowParams::iterations == kAutoIterations): the discrepancy principle on
// the input's estimated noise. docs/quality.md has the figures that chose the constants.
//
// Before the run, EstimateNoise() (core/noise.h) reads the input's noise sigma. Part of that
// reading is the estimator's own misfit on clean, coarse meshes (up to ~0.04 h on the
// benchmark's clean scans): it is removed in quadrature, sigma_n = sqrt(sigma^2 - floor^2).
// Below kNoNoiseH there is nothing to remove and the run does no iteration: a clean mesh
// comes back as it went in; so does a mesh on which too few vertices allow an estimate (a fan
// whose rim sees one circle, a strip one triangle wide). Otherwise, after every iteration, the RMS over the free interior
// vertices (every k-th one of a large mesh) of their displacement from the input along their
// current normals is compared with kDiscrepancy * sigma_n: the run stops at the first iteration that reaches it (the flow has
// moved the vertices as far as the noise had), or when an iteration adds almost nothing to it
// (the flow has converged short of it), or after kMaxAutoIterations.
//
// Noise folds thin triangles over, and a run stopped at the discrepancy can leave some folded:
// RepairFolds() then moves the free vertices of edges whose two faces face nearly opposite ways
// (normals more than kFoldAngleDeg apart: a fold, not a crease) half-way to their ring's
// centroid, a few rounds at most. Last, every flow with a step loses some volume: on a closed
// mesh the run gives the input's enclosed volume back by moving its free vertices along their
// normals by a common distance (KeepVolume): the shrinkage is a bias of the flow, not noise.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <vector>

#include "core/flows/flow.h"

namespace meshsmooth::flows {

// The estimator's misfit on clean meshes, removed in quadrature (in h).
inline constexpr double kEstimatorFloorH = 0.04;
// Below this much noise (in h, after the floor) the run does nothing.
inline constexpr double kNoNoiseH = 0.02;
// The displacement the run stops at, in units of the noise.
inline constexpr double kDiscrepancy = 1.0;
// An iteration that adds less than this share of the target to the displacement ends the run.
inline constexpr double kConvergedShare = 1e-3;
// Two faces across an edge whose normals are further apart than this are folded.
inline constexpr double kFoldAngleDeg = 120.0;
// The displacement is measured over at most about this many vertices (every k-th of a larger
// mesh): its RMS over 50,000 of them is within ~0.5% of the whole mesh's, at a fraction of the
// cost of an iteration.
inline constexpr int32_t kMaxMeasured = 50000;
// At most this many rounds of fold repair.
inline constexpr int kFoldRepairRounds = 20;

class AutoStop {
 public:
  // Reads the noise of `mesh` (the run's input; its positions are copied as the reference).
  // `role` is the run's vertex roles (core/flows/flow_kernel.h), one per vertex.
  AutoStop(const Mesh& mesh, const Topology& topo, const uint8_t* role, double h, int threads);

  // True when the input has no noise to remove: the run does no iteration.
  bool nothing_to_do() const { return !estimated_ || report_.noise_to_remove_h < kNoNoiseH; }
  // Why the run does nothing when nothing_to_do().
  StopReason idle_reason() const { return estimated_ ? StopReason::kNoNoise : StopReason::kNoEstimate; }

  // After an accepted iteration with positions `pos`: the reason to stop now, if any.
  std::optional<StopReason> After(const Vec3* pos);

  // Moves the free interior vertices of folded edges of `pos` half-way to their ring's centroid
  // until none is folded (at most kFoldRepairRounds rounds). Returns the folded vertices left.
  int64_t RepairFolds(Vec3* pos) const;

  // On a closed mesh (every vertex in use interior), moves the free vertices of `pos` along
  // their normals by the common distance that restores the input's enclosed volume.
  void KeepVolume(Vec3* pos) const;

  const AutoStopReport& report() const { return report_; }

 private:
  double RmsNormalDisplacement(const Vec3* pos) const;
  // True when a free interior vertex `v` has two consecutive faces of its ring folded.
  bool Folded(const Vec3* pos, int32_t v) const;
  // Enclosed volume of a closed mesh from the vertices' rings.
  double Volume(const Vec3* pos) const;

  const Topology& topo_;
  const uint8_t* role_;
  double h_;
  int threads_;
  std::vector<Vec3> start_;
  bool estimated_ = false;  // the noise estimate is reliable (core/noise.h)
  int32_t stride_ = 1;    // every stride_-th vertex is measured
  int64_t counted_ = 0;   // free interior vertices measured
  double cos_fold_ = std::cos(kFoldAngleDeg * std::numbers::pi / 180.0);
  bool closed_ = true;   // every vertex in use is interior
  double start_volume_ = 0.0;
  double target_ = 0.0;  // in mesh units
  double last_ = 0.0;
  AutoStopReport report_;
};

}  // namespace meshsmooth::flows
