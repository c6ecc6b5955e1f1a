// The vertex update of the normal-filtering flows (normal_filtering.h) and its guards against
// folded faces; docs/normal-filtering.md ("The vertex update", "Folded faces") gives the
// equations and why each guard is there.
#include <algorithm>
#include <cmath>

#include "core/flows/normal_filtering.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

// The tangential relaxation of a folded face's vertices, as a share of the umbrella (eq. 3).
constexpr double kUnfoldStep = 0.5;

// A face's orientation against its filtered normal in a pass's positions.
enum FaceState : uint8_t {
  kNoNormal = 0,  // no filtered normal (no area at the round's start)
  kAgrees = 1,    // its normal . the filtered normal > 0: a pass keeps it so
  kOpposes = 2,   // folded: its vertices relax tangentially
};

}  // namespace

namespace {

// FaceState of face f with cross product `cross` against the filtered normal n.
uint8_t StateOf(double area, const Vec3& cross, const Vec3& n) {
  return area == 0.0 ? kNoNormal : Dot(cross, n) > 0.0 ? kAgrees : kOpposes;
}

// The cosine between a face with cross product `cross` and the filtered normal n; -2 (below
// any cosine) for a face that has collapsed.
double CosineTo(const Vec3& cross, const Vec3& n) {
  const double len = Norm(cross);
  return len > 0.0 ? Dot(cross, n) / len : -2.0;
}

}  // namespace

void NormalFilterKernel::FitFaces(const Vec3* pos) {
  const int32_t nf = static_cast<int32_t>(graph_.faces.size());
  offset_.resize(nf);
  state_.resize(nf);
  cosine_.resize(nf);
  ForFaces([&](int32_t f) {
    const Triangle& t = graph_.faces[f];
    const Vec3 cross = FaceCross(pos, t);
    offset_[f] = Dot(normal_[f], Centroid(pos, t));
    state_[f] = StateOf(area_[f], cross, normal_[f]);
    cosine_[f] = state_[f] == kOpposes ? CosineTo(cross, normal_[f]) : 1.0;  // read for folded faces only
  });
}

void NormalFilterKernel::UpdateVertices(const StepContext& c, const Vec3* cur, int32_t n, int threads) {
  target_.resize(n);
  damping_.assign(n, 0);
  const int32_t blocks = (n + kBlock - 1) / kBlock;
  capped_.assign(blocks, 0);
  const double lambda = c.lambda;
  ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
    for (int32_t v = begin; v < end; ++v) {
      const Vec3 x = cur[v];
      if (c.role[v] == kFixed) {
        target_[v] = x;
        continue;
      }
      Vec3 f, normal;
      double weight = 0.0;
      bool folded = false;
      for (int32_t k = graph_.vertex_offsets[v]; k < graph_.vertex_offsets[v + 1]; ++k) {
        const int32_t face = graph_.vertex_faces[k];
        if (state_[face] == kNoNormal) continue;
        const Vec3& nf = normal_[face];
        const double a = area_[face];
        f += nf * (a * (offset_[face] - Dot(nf, x)));
        normal += nf * a;
        weight += a;
        folded |= state_[face] == kOpposes;
      }
      if (weight > 0.0) f *= 1.0 / weight;
      // A folded face's vertices also move tangentially towards the centroid of their ring (the
      // umbrella of eq. 3 without its normal part): the projection alone keeps a fold.
      if (folded && c.role[v] == kFree && c.offsets[v + 1] > c.offsets[v]) {
        Vec3 centre;
        for (int32_t k = c.offsets[v]; k < c.offsets[v + 1]; ++k) centre += cur[c.ring[k]];
        const Vec3 u = centre * (1.0 / (c.offsets[v + 1] - c.offsets[v])) - x;
        const double len = Norm(normal);
        const Vec3 m = len > 0.0 ? normal * (1.0 / len) : Vec3{};
        f += (u - m * Dot(m, u)) * kUnfoldStep;
      }
      if (c.threshold != nullptr) f = Threshold(f, c.threshold[v]);
      Vec3 step = f * lambda;
      const double len2 = SquaredNorm(step);
      if (len2 > c.max_step_sq) {
        step *= std::sqrt(c.max_step_sq / len2);
        ++capped_[b];
      }
      target_[v] = x + step;
    }
  });
  GuardOrientation(cur, n, threads);
}

// A vertex of a face that the moves would turn against its filtered normal moves half as far,
// then not at all, until no face turns. Every round decides from target_ as it stands, then
// writes it, so the result does not depend on the thread count; it ends because each round
// damps some vertex further and the undamped positions (cur) turn no face. The first round
// checks every face (and fits it in target_ for the next pass); later ones only the faces
// around the vertices damped in the round before.
void NormalFilterKernel::GuardOrientation(const Vec3* cur, int32_t n, int threads) {
  const Vec3* const target = target_.data();
  const int32_t nf = static_cast<int32_t>(graph_.faces.size());
  next_offset_.resize(nf);
  next_state_.resize(nf);
  next_cosine_.resize(nf);
  turned_.resize(nf);
  // A face's cosine is read only while it is folded: now (state_) or in the next pass
  // (next_state_); the square root is skipped for the others.
  auto fit = [&](int32_t f) {
    const Triangle& t = graph_.faces[f];
    next_offset_[f] = Dot(normal_[f], Centroid(target, t));
    const Vec3 cross = FaceCross(target, t);
    next_state_[f] = StateOf(area_[f], cross, normal_[f]);
    next_cosine_[f] = next_state_[f] == kOpposes || state_[f] == kOpposes ? CosineTo(cross, normal_[f]) : 1.0;
  };
  auto turns = [&](int32_t f) {
    if (state_[f] == kNoNormal) return false;
    const Vec3 cross = FaceCross(target, graph_.faces[f]);
    return state_[f] == kAgrees ? !(Dot(cross, normal_[f]) > 0.0) : CosineTo(cross, normal_[f]) < cosine_[f];
  };
  auto movable = [&](int32_t v) { return damping_[v] < 2 && !(target_[v] == cur[v]); };
  ForFaces([&](int32_t f) {
    fit(f);
    turned_[f] =
        state_[f] == kAgrees ? next_state_[f] != kAgrees : state_[f] == kOpposes && next_cosine_[f] < cosine_[f];
  });
  const int32_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<std::vector<int32_t>> found(blocks);
  ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
    for (int32_t v = begin; v < end; ++v) {
      if (!movable(v)) continue;
      for (int32_t k = graph_.vertex_offsets[v]; k < graph_.vertex_offsets[v + 1]; ++k) {
        if (turned_[graph_.vertex_faces[k]]) {
          found[b].push_back(v);
          break;
        }
      }
    }
  });
  std::vector<int32_t> damp, around, refit;
  for (const std::vector<int32_t>& f : found) damp.insert(damp.end(), f.begin(), f.end());
  stamp_.resize(n, 0);
  while (!damp.empty()) {
    ++round_;
    around.clear();
    for (int32_t v : damp) {
      ++damping_[v];
      target_[v] = damping_[v] == 1 ? cur[v] + (target_[v] - cur[v]) * 0.5 : cur[v];
      for (int32_t k = graph_.vertex_offsets[v]; k < graph_.vertex_offsets[v + 1]; ++k) {
        refit.push_back(graph_.vertex_faces[k]);
        for (int32_t u : graph_.faces[graph_.vertex_faces[k]]) {
          if (stamp_[u] != round_) stamp_[u] = round_, around.push_back(u);
        }
      }
    }
    damp.clear();
    for (int32_t u : around) {
      if (!movable(u)) continue;
      for (int32_t k = graph_.vertex_offsets[u]; k < graph_.vertex_offsets[u + 1]; ++k) {
        if (turns(graph_.vertex_faces[k])) {
          damp.push_back(u);
          break;
        }
      }
    }
  }
  for (int32_t f : refit) fit(f);  // faces whose corners the guard moved back
  offset_.swap(next_offset_);
  state_.swap(next_state_);
  cosine_.swap(next_cosine_);
}

BlockStats NormalFilterKernel::Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin,
                                    int32_t end) const {
  double max_sq = 0.0, sum = 0.0;
  int64_t moved = 0, movable = 0;
  for (int32_t v = begin; v < end; ++v) {
    next[v] = target_[v];
    if (c.role[v] == kFixed) continue;
    const double d2 = SquaredNorm(target_[v] - cur[v]);
    max_sq = std::max(max_sq, d2);
    sum += std::sqrt(d2);
    moved += d2 > 0.0;
    ++movable;
  }
  return FinishBlock(max_sq, sum, moved, movable, capped_[begin / kBlock]);
}

}  // namespace meshsmooth::flows
