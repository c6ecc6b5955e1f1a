#include "core/flows/auto_stop.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/flows/flow_kernel.h"
#include "core/measure/noise.h"
#include "core/normals.h"

namespace meshsmooth::flows {

AutoStop::AutoStop(const Mesh& mesh, const Topology& topo, const uint8_t* role, double h, int threads,
                   const NoiseEstimate* given, const std::vector<uint8_t>* measured, bool rims)
    : topo_(topo), role_(role), h_(h), threads_(threads) {
  const Vec3* const start = mesh.positions.data();
  const NoiseEstimate noise = given != nullptr ? *given : EstimateNoise(mesh, topo, h, threads);
  estimated_ = noise.reliable;
  const double floor2 = kEstimatorFloorH * kEstimatorFloorH;
  report_.noise_sigma_h = noise.sigma_h;
  report_.detail_free_h = noise.detail_free_h;
  report_.noise_to_remove_h = std::sqrt(std::max(0.0, noise.sigma_h * noise.sigma_h - floor2));
  // Fine detail, not noise: the run has nothing to remove.
  if (noise.detail_free_h < kDetailOnlyH) report_.noise_to_remove_h = 0.0;
  if (TurnsFacesVisibly(noise)) report_.noise_to_remove_h = noise.sigma_h;
  // Not less the floor: SURE weighs the fidelity to the input against the noise, and a floor
  // taken off small noise (0.06 h) makes it stop after an iteration or two.
  sigma_ = RiskSigmaH(noise) * h;
  const int32_t n = topo.num_vertices();
  stride_ = std::max<int32_t>(1, (n + kMaxMeasured - 1) / kMaxMeasured);
  has_normal_.assign(n, 0);
  for (int32_t v = 0; v < n; ++v) {
    closed_ &= topo.kind[v] == VertexKind::kInterior || topo.kind[v] == VertexKind::kIsolated;
    const bool rim = rims && topo.kind[v] == VertexKind::kBoundary;
    if (!rim && (role[v] != kFree || topo.kind[v] != VertexKind::kInterior)) continue;
    if (measured != nullptr && (*measured)[v] == 0) continue;
    if (!UnitNormal(start, v)) continue;
    has_normal_[v] = 1;
    counted_ += v % stride_ == 0;
  }
  if (closed_) start_volume_ = Volume(start);
  // Only the measured vertices' positions are kept: a large mesh's run holds 1/stride_ of them.
  start_.resize((n + stride_ - 1) / stride_);
  for (int32_t v = 0; v < n; v += stride_) start_[v / stride_] = start[v];
}

std::optional<Vec3> AutoStop::UnitNormal(const Vec3* pos, int32_t v) const {
  const Vec3 normal = RingNormal(topo_, pos, v);
  const double len = Norm(normal);
  if (!(len > 0.0) || !std::isfinite(len)) return std::nullopt;
  return normal * (1.0 / len);
}

std::vector<Vec3> AutoStop::ProbeStart(const std::vector<Vec3>& start) {
  // The normals only a run with a probe reads (Risk): a run of a count chosen beforehand (a
  // large mesh's) holds a byte per vertex, not 24.
  normal_.assign(start.size(), Vec3{});
  for (size_t v = 0; v < normal_.size(); ++v) {
    if (has_normal_[v]) normal_[v] = *UnitNormal(start.data(), static_cast<int32_t>(v));
  }
  std::vector<Vec3> probe = start;
  const double eps = kProbeStep * sigma_;
  for (size_t v = 0; v < probe.size(); ++v) probe[v] += normal_[v] * (eps * Sign(static_cast<int32_t>(v)));
  return probe;
}

double AutoStop::Sign(int32_t v) {
  // splitmix64's finaliser: consecutive vertices get independent signs.
  uint64_t z = static_cast<uint64_t>(v) + 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return ((z ^ (z >> 31)) & 1) != 0 ? 1.0 : -1.0;
}

double AutoStop::Risk(const Vec3* pos, const Vec3* probe) const {
  const int32_t n = topo_.num_vertices();
  const double eps = kProbeStep * sigma_;
  const double weight = 2.0 * sigma_ * sigma_ / eps;
  std::vector<double> block_sum((n + kBlock - 1) / kBlock, 0.0);
  ForBlocks(n, threads_, [&](int32_t b, int32_t begin, int32_t end) {
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

double AutoStop::Volume(const Vec3* pos) const {
  // Each face (v, a, b) around v contributes v . (a x b) / 6, and is met at its three corners.
  // Around a closed ring the sum of (a - v) x (b - v) equals the sum of a x b, so the corner's
  // share is v . RingNormal(v), the ring walk the displacement and KeepVolume use too.
  const int32_t n = topo_.num_vertices();
  std::vector<double> block_sum((n + kBlock - 1) / kBlock, 0.0);
  ForBlocks(n, threads_, [&](int32_t b, int32_t begin, int32_t end) {
    double sum = 0.0;
    for (int32_t v = begin; v < end; ++v) sum += Dot(pos[v], RingNormal(topo_, pos, v));
    block_sum[b] = sum;
  });
  double total = 0.0;
  for (double s : block_sum) total += s;
  return total / 18.0;
}

AutoStop::Fold AutoStop::Folded(const Vec3* pos, int32_t v) const {
  if (role_[v] == kCurve) return RimFolded(pos, v) ? kFolded : kNotFolded;
  if (role_[v] != kFree || topo_.kind[v] != VertexKind::kInterior) return kNotFolded;
  if (FanFolds(pos, topo_, v)) return kFanFolded;
  return ForFoldedEdges(pos, topo_, v, cos_fold_, [](int32_t) { return true; }) ? kFolded : kNotFolded;
}

bool AutoStop::SlideToUnfold(const Vec3* pos, int32_t v, const Vec3& normal, Vec3& to) const {
  const int32_t first = topo_.ring_offsets[v], last = topo_.ring_offsets[v + 1];
  to = pos[v];
  for (int sweep = 0; sweep < kUnfoldSweeps; ++sweep) {
    bool unfolded = true;
    for (int32_t k = first; k < last; ++k) {
      const Vec3 a = pos[topo_.ring[k]], b = pos[topo_.ring[k + 1 < last ? k + 1 : first]];
      // Twice the projected area of face (to, a, b), Dot(Cross(a - to, b - to), normal), is
      // linear in `to` and grows along `rise` = normal x (b - a), whose squared length is that
      // of the far edge: a height of kUnfoldHeight |b - a| is twice the area kUnfoldHeight |rise|^2.
      const Vec3 rise = Cross(normal, b - a);
      const double edge2 = Dot(rise, rise);
      if (!(edge2 > 0.0)) continue;
      const double twice_area = Dot(Cross(a - to, b - to), normal);
      const double wanted = kUnfoldHeight * edge2;
      if (twice_area >= 0.5 * wanted) continue;
      unfolded = false;
      to += rise * ((wanted - twice_area) / edge2);
    }
    if (unfolded) return true;
  }
  return false;
}

bool AutoStop::RimFolded(const Vec3* pos, int32_t v) const {
  const int32_t first = topo_.ring_offsets[v], last = topo_.ring_offsets[v + 1];
  if (last - first < 2) return false;
  if (FanFolds(pos, topo_, v)) return true;
  const Vec3 p = pos[v];
  Vec3 prev = pos[topo_.ring[first]] - p;
  for (int32_t k = first + 1; k < last; ++k) {
    const Vec3 cur = pos[topo_.ring[k]] - p;
    if (Dot(prev, cur) < cos_rim_needle_ * Norm(prev) * Norm(cur)) return true;
    prev = cur;
  }
  return false;
}

int64_t AutoStop::RepairFolds(Vec3* pos) const {
  const int32_t n = topo_.num_vertices();
  // The folded vertices, found once over the mesh, then followed on their own (a round moves
  // only them, and only they are checked again): the repair costs nothing where nothing is
  // folded.
  std::vector<uint8_t> folded(n, 0);
  ForBlocks(n, threads_, [&](int32_t, int32_t begin, int32_t end) {
    for (int32_t v = begin; v < end; ++v) folded[v] = Folded(pos, v);
  });
  std::vector<int32_t> list;
  std::vector<uint8_t> fold;  // Folded()'s answer for each vertex of the list, as it stands
  for (int32_t v = 0; v < n; ++v) {
    if (folded[v] == kNotFolded) continue;
    list.push_back(v);
    fold.push_back(folded[v]);
  }
  // Each vertex's position before the repair: no round takes it further than
  // kFoldRepairReachH h from there.
  std::vector<Vec3> origin(list.size()), moved(list.size());
  for (size_t i = 0; i < list.size(); ++i) origin[i] = pos[list[i]];
  const double reach = kFoldRepairReachH * h_, slide_reach = kUnfoldSlideH * h_;
  for (int round = 0; round < kFoldRepairRounds && !list.empty(); ++round) {
    for (size_t i = 0; i < list.size(); ++i) {  // Jacobi: every move reads the round's start
      const int32_t v = list[i];
      const int32_t first = topo_.ring_offsets[v], last = topo_.ring_offsets[v + 1];
      // An interior vertex (Folded) whose fan turns a face against its ring, a fold within the
      // ring's plane, slides; one whose edges fold out of the plane goes to the centroid.
      if (fold[i] == kFanFolded) {  // its ring's normal does not depend on pos[v]
        Vec3 normal = RingNormal(topo_, pos, v), to;
        const double length = Norm(normal);
        if (length > 0.0 && std::isfinite(length)) {
          normal *= 1.0 / length;
          if (SlideToUnfold(pos, v, normal, to)) {
            const Vec3 total = to - origin[i];
            const double along = Dot(total, normal);
            Vec3 across = total - normal * along;
            const double slid = Norm(across);
            if (slid > slide_reach) across *= slide_reach / slid;
            moved[i] = origin[i] + across + normal * std::clamp(along, -reach, reach);
            continue;
          }
        }
      }
      Vec3 centroid;
      if (role_[v] == kCurve) {  // its neighbours along the loop: the first and last of its ring
        centroid = (pos[topo_.ring[first]] + pos[topo_.ring[last - 1]]) * 0.5;
      } else {
        for (int32_t k = first; k < last; ++k) centroid += pos[topo_.ring[k]];
        centroid *= 1.0 / static_cast<double>(last - first);
      }
      moved[i] = pos[v] + (centroid - pos[v]) * 0.5;
      const Vec3 total = moved[i] - origin[i];
      const double length = Norm(total);
      if (length > reach) moved[i] = origin[i] + total * (reach / length);
    }
    for (size_t i = 0; i < list.size(); ++i) pos[list[i]] = moved[i];
    size_t kept = 0;
    for (size_t i = 0; i < list.size(); ++i) {
      const Fold f = Folded(pos, list[i]);
      if (f == kNotFolded) continue;
      list[kept] = list[i];
      fold[kept] = f;
      origin[kept++] = origin[i];
    }
    list.resize(kept);
    fold.resize(kept);
    origin.resize(kept);
    moved.resize(kept);
  }
  return static_cast<int64_t>(list.size());
}

void AutoStop::KeepVolume(Vec3* pos) const {
  if (!closed_ || counted_ == 0) return;
  const int32_t n = topo_.num_vertices();
  std::vector<Vec3> unit(n);
  std::vector<double> block_rate((n + kBlock - 1) / kBlock, 0.0);
  // A few Newton steps on the common offset d: dV/dd = sum over the free vertices of
  // |RingNormal| / 6 (the gradient of the volume at v is RingNormal(v) / 6).
  for (int step = 0; step < 3; ++step) {
    ForBlocks(n, threads_, [&](int32_t b, int32_t begin, int32_t end) {
      double rate = 0.0;
      for (int32_t v = begin; v < end; ++v) {
        unit[v] = {};
        if (role_[v] != kFree || topo_.kind[v] != VertexKind::kInterior) continue;
        const Vec3 normal = RingNormal(topo_, pos, v);
        const double len = Norm(normal);
        if (!(len > 0.0) || !std::isfinite(len)) continue;
        unit[v] = normal * (1.0 / len);
        rate += len / 6.0;
      }
      block_rate[b] = rate;
    });
    double rate = 0.0;
    for (double r : block_rate) rate += r;
    const double gap = start_volume_ - Volume(pos);
    if (!(rate > 0.0) || !std::isfinite(gap)) return;
    const double d = gap / rate;
    // A correction of more than a mean edge length is not a flow's shrinkage: leave it.
    if (!(std::abs(d) <= h_)) return;
    for (int32_t v = 0; v < n; ++v) pos[v] += unit[v] * d;
  }
}

double AutoStop::RmsNormalDisplacement(const Vec3* pos) const {
  const int32_t n = topo_.num_vertices();
  std::vector<double> block_sum((n + kBlock - 1) / kBlock, 0.0);
  ForBlocks(n, threads_, [&](int32_t b, int32_t begin, int32_t end) {
    double sum = 0.0;
    for (int32_t v = begin; v < end; ++v) {
      if (v % stride_ != 0 || !has_normal_[v]) continue;  // the measured vertices
      const Vec3 normal = RingNormal(topo_, pos, v);
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

std::optional<StopReason> AutoStop::After(int it, const Vec3* pos, const Vec3* probe) {
  const double risk = Risk(pos, probe);
  risks_.push_back(risk);
  improved_ = best_it_ == 0 || risk < best_risk_;
  if (improved_) {
    best_risk_ = risk;
    best_it_ = it;
    report_.risk_h2 = (risk - sigma_ * sigma_) / (h_ * h_);
  }
  if (rival_ && it > 2 * kRivalWindow) {  // two full windows of decreases
    const double last = risks_[it - 1 - kRivalWindow] - risk;
    const double before = risks_[it - 1 - 2 * kRivalWindow] - risks_[it - 1 - kRivalWindow];
    if (last > 0.0 && before > last) {
      const double rate = last / before;  // the geometric series of the decreases to come
      if (risk - kRivalReach * last * rate / (1.0 - rate) > *rival_) return StopReason::kNoiseRemoved;
    }
  }
  const int stretch = std::max(kPatience, it / 2);
  if (it - best_it_ >= std::max(kPatience, best_it_ / 2)) return StopReason::kNoiseRemoved;
  if (it > stretch && risks_[it - 1 - stretch] - best_risk_ < kConvergedShare * sigma_ * sigma_) {
    return StopReason::kConverged;
  }
  return std::nullopt;
}

}  // namespace meshsmooth::flows
