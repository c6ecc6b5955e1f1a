// Every number the default job was tuned with, one line each; the section of docs/decisions.md
// named beside a group has the figures that chose them and the ablations. docs/quality-method.md
// says why the method is the one it is. The noise estimator's numbers are its NoiseParams
// (core/measure/noise.h), held here as `noise`; the candidates' list, the sample's threshold and
// the small holes' size are the catalogue's (core/flows/catalogue.h), which the help texts quote.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

#include "core/flows/catalogue.h"
#include "core/measure/noise.h"

namespace meshsmooth::job {

struct JobPolicy {
  // Reading the noise ("Automatic stopping: Stein's unbiased risk estimate", "Detail read as
  // noise: a second, wider fit").
  double no_noise_h = 0.02;     // below this much noise to remove (in h) the run does nothing
  double detail_only_h = 0.03;  // ... nor below this detail-free estimate (in h)

  // Outliers ("Outliers").
  double impulsive_share = 0.04;  // above this share of outlying fits the outliers move back first
  int outlier_rounds = 3;         // at most this many rounds of moving them
  int unfold_rounds = 6;          // ... then at most this many rounds of unfolding their fans

  // The risk estimate's stop ("Automatic stopping: Stein's unbiased risk estimate").
  int patience = 8;                // no better iteration for this many (and half the best's count)
  double converged_share = 1e-2;   // ... or a gain below this share of sigma^2 a vertex over that stretch
  double risk_sigma_margin = 1.1;  // the deviation is taken this much high
  double probe_step = 0.05;        // the probe moves by +-this many sigma along the normals
  int32_t max_measured = 50000;    // the estimate is summed over at most about this many vertices

  // The choice between candidates ("The default job chooses on a sample").
  int rival_window = 4;        // a losing candidate's decrease is extrapolated over this many
  double rival_reach = 2.0;    // ... times this much of what it would still fall
  int32_t sample_share = 16;   // a sample holds one vertex in this many of the mesh's...
  int32_t min_sample = 10000;  // ... at least this many
  int32_t max_sample = 20000;  // ... at most this many
  int32_t min_patch = 2500;    // in patches of at least this many vertices
  int32_t max_patches = 8;     // ... at most this many patches
  int32_t core_percent = 60;   // measured within this percent of a patch's radius, in rings
  double sample_bias = 0.025;  // a later candidate wins on a sample by this share of sigma^2

  // Fold repair ("Fold repair, within 0.2 h").
  double fold_angle_deg = 120.0;        // two faces across an edge further apart than this are folded
  double rim_needle_angle_deg = 160.0;  // a rim vertex with a face angle above this is folded
  int fold_repair_rounds = 20;          // at most this many rounds of repair
  double fold_repair_reach_h = 0.2;     // no vertex moves further than this (in h)
  double unfold_height = 0.05;          // a slid vertex leaves each face this height over its far edge
  int unfold_sweeps = 30;               // ... found in at most this many sweeps over its fan
  double unfold_slide_h = 1.0;          // ... no further than this (in h) within its ring's plane

  // Noise the risk estimate cannot read ("Noise the risk estimate cannot read").
  double visible_turn_deg = 6.5;             // noise turning the faces this far (degrees) is noise...
  double visible_crease_share = 0.2;         // ... on a mesh with at most this share of crease vertices
  double risk_turn_share = 0.75;             // the risk's result turned less than this share: the turn rule runs
  double discrepancy_turn_share = 1.25;      // the turn rule's target, times the predicted turn
  int32_t max_whole_turn_vertices = 200000;  // the turn rule chooses on the whole mesh up to this size

  // The noise estimator's numbers ("The noise estimator's numbers in the policy").
  NoiseParams noise;
};

// Today's policy: the one every job runs with. A benchmark's ablation runs another
// (job::SmoothWithPolicy, default_job.h).
inline constexpr JobPolicy kPolicy{};

// Calls visit(name, field) for every field of `policy`, in the order above (`field` a double& or
// an int32_t&): for listing the numbers and setting them by name.
template <typename Visit>
void VisitPolicy(JobPolicy& policy, Visit visit) {
  visit("no_noise_h", policy.no_noise_h);
  visit("detail_only_h", policy.detail_only_h);
  visit("impulsive_share", policy.impulsive_share);
  visit("outlier_rounds", policy.outlier_rounds);
  visit("unfold_rounds", policy.unfold_rounds);
  visit("patience", policy.patience);
  visit("converged_share", policy.converged_share);
  visit("risk_sigma_margin", policy.risk_sigma_margin);
  visit("probe_step", policy.probe_step);
  visit("max_measured", policy.max_measured);
  visit("rival_window", policy.rival_window);
  visit("rival_reach", policy.rival_reach);
  visit("sample_share", policy.sample_share);
  visit("min_sample", policy.min_sample);
  visit("max_sample", policy.max_sample);
  visit("min_patch", policy.min_patch);
  visit("max_patches", policy.max_patches);
  visit("core_percent", policy.core_percent);
  visit("sample_bias", policy.sample_bias);
  visit("fold_angle_deg", policy.fold_angle_deg);
  visit("rim_needle_angle_deg", policy.rim_needle_angle_deg);
  visit("fold_repair_rounds", policy.fold_repair_rounds);
  visit("fold_repair_reach_h", policy.fold_repair_reach_h);
  visit("unfold_height", policy.unfold_height);
  visit("unfold_sweeps", policy.unfold_sweeps);
  visit("unfold_slide_h", policy.unfold_slide_h);
  visit("visible_turn_deg", policy.visible_turn_deg);
  visit("visible_crease_share", policy.visible_crease_share);
  visit("risk_turn_share", policy.risk_turn_share);
  visit("discrepancy_turn_share", policy.discrepancy_turn_share);
  visit("max_whole_turn_vertices", policy.max_whole_turn_vertices);
  visit("noise.max_fits", policy.noise.max_fits);
  visit("noise.min_fit_points", policy.noise.min_fit_points);
  visit("noise.min_well_posed", policy.noise.min_well_posed);
  visit("noise.well_posed_share", policy.noise.well_posed_share);
  visit("noise.crease_sharp_deg", policy.noise.crease_sharp_deg);
  visit("noise.crease_flat_deg", policy.noise.crease_flat_deg);
  visit("noise.max_crease_share", policy.noise.max_crease_share);
  visit("noise.outlier_scales", policy.noise.outlier_scales);
  visit("noise.outlier_floor_h", policy.noise.outlier_floor_h);
  visit("noise.lmeds_triples", policy.noise.lmeds_triples);
  visit("noise.lmeds_inlier_scales", policy.noise.lmeds_inlier_scales);
  visit("noise.lmeds_floor_h", policy.noise.lmeds_floor_h);
  visit("noise.max_wide_fits", policy.noise.max_wide_fits);
  visit("noise.noise_wide_ratio", policy.noise.noise_wide_ratio);
  visit("noise.detail_wide_ratio", policy.noise.detail_wide_ratio);
}

// The sigma the risk estimate works with, in h: the noise's deviation taken risk_sigma_margin high.
inline double RiskSigmaH(const NoiseEstimate& noise, const JobPolicy& policy) {
  return policy.risk_sigma_margin * noise.deviation_h;
}

// True when the noise `noise` reads turns its mesh's faces visibly: the turn rule may take over
// (a fused scan's thin triangles turn far under small offsets; a CAD part of slivers turns them
// far under any offset, and a run only slides vertices along them).
inline bool TurnsFacesVisibly(const NoiseEstimate& noise, const JobPolicy& policy) {
  return noise.normal_turn * 180.0 / std::numbers::pi >= policy.visible_turn_deg &&
         noise.crease_share <= policy.visible_crease_share;
}

}  // namespace meshsmooth::job
