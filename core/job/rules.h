// How the default job's runs stop, and what they do with their result: the stop rules it gives
// the driver (core/flows/driver.h). A JobPolicy (policy.h) holds their numbers; docs/decisions.md
// has the figures that chose them.
//
// Every run (JobRule) reads the input's noise (NoiseEstimate, core/measure/noise.h). Below
// no_noise_h there is nothing to remove and the run does no iteration: a clean mesh comes back as
// it went in; so does a mesh without a reliable estimate (too few fits, or a mesh almost all
// creases), and one whose detail-free estimate is below detail_only_h (fine detail, not noise)
// unless its noise turns the faces visibly. After the run, on the positions it returns: the folds
// are repaired (repair.h) and a closed mesh gets its volume back (every flow with a step loses
// some: a bias of the flow, not noise).
//
// RiskStop keeps the iteration whose error to the noise-free surface is least by Stein's
// unbiased risk estimate (SURE; Stein 1981), in its Monte-Carlo form for any denoiser (Ramani,
// Blu, Unser 2008). With y the input's offsets along its normals N, noise of deviation sigma in
// them, and f_k(y) the offsets after k iterations,
// E|f_k(y) - x|^2 = E[ |f_k(y) - y|^2 - n sigma^2 + 2 sigma^2 div f_k(y) ], and the divergence is
// div f_k ~ b . (f_k(y + eps b) - f_k(y)) / eps for a random sign vector b: a probe copy of the
// input, moved by eps b along N, runs the same flow beside the real one. Both terms are summed
// over the measured free interior vertices (every k-th one of a large mesh). The run stops once
// the estimate has not improved for `patience` iterations and half as many as the best one took
// ("noise_removed"), when it improves by less than converged_share of sigma^2 a vertex over that
// stretch ("converged"), or at the cap, and returns the best iteration. sigma is the estimate's
// root mean square (NoiseEstimate::deviation_h), not its robust scale: SURE needs the variance.
//
// TurnStop is the discrepancy principle on the face normals, for noise the risk estimate cannot
// read: SURE assumes noise independent from vertex to vertex, and a fused scan's is correlated
// over many edges (the estimate reads most of it as shape). A run has removed the noise once the
// faces have turned, on average, as far as the noise turns them (NoiseEstimate::normal_turn).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/flows/driver.h"
#include "core/flows/flow.h"
#include "core/job/policy.h"
#include "core/measure/noise.h"
#include "core/measure/normal_turn.h"

namespace meshsmooth::job {

// A run of a count chosen beforehand (flows::RunPlan::fixed_iterations), and what every run of
// the default job shares: the noise's report and the decision whether there is anything to do
// (Start), the displacement, fold repair and volume (Finish).
class JobRule : public flows::StopRule {
 public:
  // `noise`: the input's, read once by the job. `measured` (null: all) the vertices the estimate
  // measures, among the free interior ones, and with `rims` the boundary ones too, whatever
  // their role (a fixed rim keeps its noise: the estimate counts it). `repair_idle`: the input
  // was changed before the run (outliers moved): a run with nothing to do still repairs the
  // folds the change left.
  JobRule(double h, const NoiseEstimate& noise, const JobPolicy& policy, const std::vector<uint8_t>* measured = nullptr,
          bool rims = false, bool repair_idle = false);

  std::optional<StopReason> Start(const Mesh& input, const Topology& topo, const uint8_t* role, int threads) override;
  std::optional<StopReason> After(int, const Vec3*, const Vec3*) override { return std::nullopt; }
  void Finish(Vec3* pos, FlowResult& result) override;

 protected:
  // True when the input has no noise to remove (Start's answer unless a rule overrides it).
  bool nothing_to_do() const { return !estimated_ || report_.noise_to_remove_h < policy_.no_noise_h; }
  double RmsNormalDisplacement(const Vec3* pos) const;
  // The unit normal of the ring at v in `pos`, or none where the ring has no area.
  std::optional<Vec3> UnitNormal(const Vec3* pos, int32_t v) const;

  const JobPolicy& policy_;
  const std::vector<uint8_t>* measured_;
  const bool rims_, repair_idle_;
  const double h_;
  const Topology* topo_ = nullptr;
  const uint8_t* role_ = nullptr;
  int threads_ = 1;
  bool idle_ = false;
  bool estimated_ = false;           // the noise estimate is reliable (core/measure/noise.h)
  int32_t stride_ = 1;               // every stride_-th vertex is measured
  int64_t counted_ = 0;              // free interior vertices measured
  std::vector<Vec3> start_;          // the input's position of every stride_-th vertex
  std::vector<uint8_t> has_normal_;  // per vertex: one of the measured vertices, with a normal
  bool closed_ = true;               // every vertex in use is interior
  double start_volume_ = 0.0;
  double sigma_ = 0.0;  // the deviation the risk estimate works with, in mesh units
  AutoStopReport report_;
};

// SURE (above): the least estimated error.
class RiskStop final : public JobRule {
 public:
  using JobRule::JobRule;

  bool wants_probe() const override { return true; }
  // `start` moved by +-probe_step sigma along its normals.
  std::vector<Vec3> ProbeStart(const std::vector<Vec3>& start) override;
  std::optional<StopReason> After(int it, const Vec3* pos, const Vec3* probe) override;
  int best_iteration() const override { return best_it_; }

  // After() stops the run ("noise_removed") once its estimate cannot reach `risk_h2` (a
  // rival's AutoStopReport::risk_h2 on the same input): the run then loses to the rival. It gives
  // up once its estimate, less rival_reach times what it would still fall if its decrease over the
  // last rival_window iterations kept shrinking at the rate it shrank from the window before,
  // stays above the rival's.
  void SetRival(double risk_h2) { rival_h2_ = risk_h2; }

 private:
  // SURE of `pos` less its constant n sigma^2, a vertex, over the measured vertices.
  double Risk(const Vec3* pos, const Vec3* probe) const;
  // The probe's sign at vertex v: +1 or -1, from a hash of v (the same for any thread count).
  static double Sign(int32_t v);

  std::vector<Vec3> normal_;  // ProbeStart's: the measured vertices' unit normals, else zero
  double best_risk_ = 0.0;
  int best_it_ = 0;
  std::vector<double> risks_;       // of every iteration so far
  std::optional<double> rival_h2_;  // SetRival's
};

// The discrepancy principle (above): "noise_removed" once the faces turned by `target` radians;
// "converged" once, over the last half of the run (at least 2 `patience` iterations), the turn
// grew by less than converged_share of the target. Never idle: the job runs it only on noise it
// has read.
class TurnStop final : public JobRule {
 public:
  TurnStop(double h, const NoiseEstimate& noise, const JobPolicy& policy, double target, bool rims)
      : JobRule(h, noise, policy, nullptr, rims), target_(target) {}

  std::optional<StopReason> Start(const Mesh& input, const Topology& topo, const uint8_t* role, int threads) override;
  std::optional<StopReason> After(int it, const Vec3* pos, const Vec3* probe) override;

 private:
  std::optional<NormalTurn> turn_;
  double target_;
  std::vector<double> turns_;  // after every iteration
};

}  // namespace meshsmooth::job
