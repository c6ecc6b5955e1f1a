// The numbers the default job's turn rules were tuned with, one line each (docs/decisions.md,
// "Noise the risk estimate cannot read", has the figures that chose them and the ablations;
// docs/quality-method.md says why the rules are these). The risk estimate's own constants are in
// auto_stop.h.
#pragma once

#include <cstdint>
#include <numbers>

#include "core/measure/noise.h"

namespace meshsmooth::flows {

struct JobPolicy {
  // Noise turning the faces by at least this many degrees (NoiseEstimate::normal_turn) is noise,
  // whatever its size in h: a fused scan's thin triangles turn far under small offsets.
  double visible_turn_deg = 6.5;
  // ... on a mesh with at most this share of its vertices on creases (a noisy CAD part of
  // slivers turns them far under any offset, and a run only slides vertices along them).
  double visible_crease_share = 0.2;
  // The risk estimate's best iteration turned the faces by less than this share of the
  // predicted turn: the noise is not independent, and the discrepancy rule (discrepancy.h) runs.
  double risk_turn_share = 0.75;
  // The discrepancy rule's target, times the predicted turn (the fits miss the part of a
  // correlated noise they read as shape).
  double discrepancy_turn_share = 1.25;
  // The discrepancy rule chooses on the whole mesh up to this many vertices, above on a sample.
  int32_t max_whole_turn_vertices = 200000;
};

inline constexpr JobPolicy kJobPolicy{};

// True when the noise `noise` reads turns its mesh's faces visibly (the first two numbers).
inline bool TurnsFacesVisibly(const NoiseEstimate& noise, const JobPolicy& policy = kJobPolicy) {
  return noise.normal_turn * 180.0 / std::numbers::pi >= policy.visible_turn_deg &&
         noise.crease_share <= policy.visible_crease_share;
}

}  // namespace meshsmooth::flows
