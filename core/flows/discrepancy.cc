#include "core/flows/discrepancy.h"

#include "core/flows/auto_stop.h"

namespace meshsmooth::flows {

void DiscrepancyStop::Start(const Mesh& input, const Topology& topo) {
  turn_.emplace(input, topo);
  turns_.clear();
}

std::optional<StopReason> DiscrepancyStop::After(int iteration, const Vec3* pos) {
  turns_.push_back(turn_->Of(pos));
  if (turns_.back() >= target_) return StopReason::kNoiseRemoved;
  if (iteration >= 2 * kPatience && turns_.back() - turns_[iteration / 2 - 1] < kConvergedShare * target_) {
    return StopReason::kConverged;
  }
  return std::nullopt;
}

}  // namespace meshsmooth::flows
