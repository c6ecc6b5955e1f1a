// The discrepancy principle on the face normals, for noise the risk estimate cannot read. A
// run has removed the noise once the faces have turned, on average, as far as the noise turned
// them (NoiseEstimate::normal_turn, core/measure/normal_turn.h): unlike the risk estimate
// (auto_stop.h), this does not assume the noise independent from vertex to vertex. A scanner's
// fused scan is not: its noise is correlated over many edges, the risk estimate reads most of
// it as shape and stops after an iteration or two (choice.cc says when the default job turns to
// this rule instead).
#pragma once

#include <optional>
#include <vector>

#include "core/flows/driver.h"
#include "core/measure/normal_turn.h"

namespace meshsmooth::flows {

// "noise_removed" once the faces turned by `target` radians; "converged" once, over the last
// half of the run (at least 2 kPatience iterations, auto_stop.h), the turn grew by less than
// kConvergedShare of the target.
class DiscrepancyStop final : public StopRule {
 public:
  explicit DiscrepancyStop(double target) : target_(target) {}
  void Start(const Mesh& input, const Topology& topo) override;
  std::optional<StopReason> After(int iteration, const Vec3* pos) override;
  double turn() const { return turns_.empty() ? 0.0 : turns_.back(); }

 private:
  std::optional<NormalTurn> turn_;
  double target_;
  std::vector<double> turns_;  // after every iteration
};

}  // namespace meshsmooth::flows
