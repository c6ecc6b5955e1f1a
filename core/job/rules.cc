#include "core/job/rules.h"

#include <algorithm>
#include <cmath>

#include "core/flows/flow_kernel.h"
#include "core/job/repair.h"
#include "core/normals.h"

namespace meshsmooth::job {

using flows::kBlock;
using flows::kFree;

JobRule::JobRule(double h, const NoiseEstimate& noise, const JobPolicy& policy, const std::vector<uint8_t>* measured,
                 bool rims, bool repair_idle)
    : policy_(policy), measured_(measured), rims_(rims), repair_idle_(repair_idle), h_(h) {
  estimated_ = noise.reliable;
  report_.noise_sigma_h = noise.sigma_h;
  report_.detail_free_h = noise.detail_free_h;
  // Fine detail, not noise, unless the noise turns the faces visibly: nothing to remove.
  const bool detail_only = noise.detail_free_h < policy_.detail_only_h && !TurnsFacesVisibly(noise, policy);
  report_.noise_to_remove_h = detail_only ? 0.0 : noise.sigma_h;
  sigma_ = RiskSigmaH(noise, policy) * h;
}

std::optional<StopReason> JobRule::Start(const Mesh& input, const Topology& topo, const uint8_t* role, int threads) {
  topo_ = &topo;
  role_ = role;
  threads_ = threads;
  const Vec3* const start = input.positions.data();
  const int32_t n = topo.num_vertices();
  stride_ = std::max<int32_t>(1, (n + policy_.max_measured - 1) / policy_.max_measured);
  has_normal_.assign(n, 0);
  closed_ = true;
  counted_ = 0;
  for (int32_t v = 0; v < n; ++v) {
    closed_ &= topo.kind[v] == VertexKind::kInterior || topo.kind[v] == VertexKind::kIsolated;
    const bool rim = rims_ && topo.kind[v] == VertexKind::kBoundary;
    if (!rim && (role[v] != kFree || topo.kind[v] != VertexKind::kInterior)) continue;
    if (measured_ != nullptr && (*measured_)[v] == 0) continue;
    if (!UnitNormal(start, v)) continue;
    has_normal_[v] = 1;
    counted_ += v % stride_ == 0;
  }
  if (closed_) start_volume_ = EnclosedVolume(start, topo, threads_);
  // Only the measured vertices' positions are kept: a large mesh's run holds 1/stride_ of them.
  start_.resize((n + stride_ - 1) / stride_);
  for (int32_t v = 0; v < n; v += stride_) start_[v / stride_] = start[v];
  idle_ = nothing_to_do();
  if (!idle_) return std::nullopt;
  return estimated_ ? StopReason::kNoNoise : StopReason::kNoEstimate;
}

std::optional<Vec3> JobRule::UnitNormal(const Vec3* pos, int32_t v) const {
  const Vec3 normal = RingNormal(*topo_, pos, v);
  const double len = Norm(normal);
  if (!(len > 0.0) || !std::isfinite(len)) return std::nullopt;
  return normal * (1.0 / len);
}

double JobRule::RmsNormalDisplacement(const Vec3* pos) const {
  const int32_t n = topo_->num_vertices();
  std::vector<double> block_sum((n + kBlock - 1) / kBlock, 0.0);
  flows::ForBlocks(n, threads_, [&](int32_t b, int32_t begin, int32_t end) {
    double sum = 0.0;
    for (int32_t v = begin; v < end; ++v) {
      if (v % stride_ != 0 || !has_normal_[v]) continue;  // the measured vertices
      const Vec3 normal = RingNormal(*topo_, pos, v);
      const double len = Norm(normal);
      if (!(len > 0.0)) continue;
      const double d = Dot(pos[v] - start_[v / stride_], normal) / len;
      sum += d * d;
    }
    block_sum[b] = sum;
  });
  double total = 0.0;
  for (double s : block_sum) total += s;  // block order: the same sum for any thread count
  return counted_ > 0 ? std::sqrt(total / static_cast<double>(counted_)) : 0.0;
}

void JobRule::Finish(Vec3* pos, FlowResult& result) {
  result.auto_stop = report_;
  const FoldRepair repair(*topo_, role_, h_, threads_, policy_);
  if (idle_) {
    if (!repair_idle_) return;
    // What moving the outliers left folded: the displacement is the repair's.
    repair.Run(pos);
    result.auto_stop->displacement_h = RmsNormalDisplacement(pos) / h_;
    return;
  }
  result.auto_stop->displacement_h = RmsNormalDisplacement(pos) / h_;
  repair.Run(pos);
  if (closed_ && counted_ > 0) RestoreVolume(pos, *topo_, role_, h_, threads_, start_volume_);
}

std::vector<Vec3> RiskStop::ProbeStart(const std::vector<Vec3>& start) {
  // The normals only a run with a probe reads (Risk): a run of a count chosen beforehand (a
  // large mesh's) holds a byte per vertex, not 24.
  normal_.assign(start.size(), Vec3{});
  for (size_t v = 0; v < normal_.size(); ++v) {
    if (has_normal_[v]) normal_[v] = *UnitNormal(start.data(), static_cast<int32_t>(v));
  }
  std::vector<Vec3> probe = start;
  const double eps = policy_.probe_step * sigma_;
  for (size_t v = 0; v < probe.size(); ++v) probe[v] += normal_[v] * (eps * Sign(static_cast<int32_t>(v)));
  return probe;
}

double RiskStop::Sign(int32_t v) {
  // splitmix64's finaliser: consecutive vertices get independent signs.
  uint64_t z = static_cast<uint64_t>(v) + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return ((z ^ (z >> 31)) & 1) != 0 ? 1.0 : -1.0;
}

double RiskStop::Risk(const Vec3* pos, const Vec3* probe) const {
  const int32_t n = topo_->num_vertices();
  const double eps = policy_.probe_step * sigma_;
  const double weight = 2.0 * sigma_ * sigma_ / eps;
  std::vector<double> block_sum((n + kBlock - 1) / kBlock, 0.0);
  flows::ForBlocks(n, threads_, [&](int32_t b, int32_t begin, int32_t end) {
    double sum = 0.0;
    for (int32_t v = begin; v < end; ++v) {
      if (v % stride_ != 0 || normal_[v] == Vec3{}) continue;
      const double d = Dot(pos[v] - start_[v / stride_], normal_[v]);
      const double slope = Dot(probe[v] - pos[v], normal_[v]) * Sign(v);
      sum += d * d + weight * slope;
    }
    block_sum[b] = sum;
  });
  double total = 0.0;
  for (double s : block_sum) total += s;  // block order: the same sum for any thread count
  return counted_ > 0 ? total / static_cast<double>(counted_) : 0.0;
}

std::optional<StopReason> RiskStop::After(int it, const Vec3* pos, const Vec3* probe) {
  const double risk = Risk(pos, probe);
  risks_.push_back(risk);
  if (best_it_ == 0 || risk < best_risk_) {
    best_risk_ = risk;
    best_it_ = it;
    report_.risk_h2 = (risk - sigma_ * sigma_) / (h_ * h_);
  }
  const int window = policy_.rival_window;
  if (rival_h2_ && it > 2 * window) {  // two full windows of decreases
    const double rival = *rival_h2_ * h_ * h_ + sigma_ * sigma_;
    const double last = risks_[it - 1 - window] - risk;
    const double before = risks_[it - 1 - 2 * window] - risks_[it - 1 - window];
    if (last > 0.0 && before > last) {
      const double rate = last / before;  // the geometric series of the decreases to come
      if (risk - policy_.rival_reach * last * rate / (1.0 - rate) > rival) return StopReason::kNoiseRemoved;
    }
  }
  const int stretch = std::max(policy_.patience, it / 2);
  if (it - best_it_ >= std::max(policy_.patience, best_it_ / 2)) return StopReason::kNoiseRemoved;
  if (it > stretch && risks_[it - 1 - stretch] - best_risk_ < policy_.converged_share * sigma_ * sigma_) {
    return StopReason::kConverged;
  }
  return std::nullopt;
}

std::optional<StopReason> TurnStop::Start(const Mesh& input, const Topology& topo, const uint8_t* role, int threads) {
  JobRule::Start(input, topo, role, threads);
  idle_ = false;
  turn_.emplace(input, topo);
  turns_.clear();
  return std::nullopt;
}

std::optional<StopReason> TurnStop::After(int it, const Vec3* pos, const Vec3*) {
  turns_.push_back(turn_->Of(pos));
  if (turns_.back() >= target_) return StopReason::kNoiseRemoved;
  if (it >= 2 * policy_.patience && turns_.back() - turns_[it / 2 - 1] < policy_.converged_share * target_) {
    return StopReason::kConverged;
  }
  return std::nullopt;
}

}  // namespace meshsmooth::job
