// The vertex update of the normal-filtering flows (normal_filtering.h) and its guards against
// folded faces; docs/normal-filtering.md ("The vertex update", "Folded faces") gives the
// equations and why each guard is there.
//
// The update's sum over the faces of v, sum_f A_f n_f (n_f . (c_f - x_v)), is computed as
// sum_f q_f - M_v x_v with q_f = A_f (n_f . c_f) n_f and M_v = sum_f A_f n_f n_f^T: a pass is
// then one loop over the faces, which fits each face to the pass's positions (its orientation,
// the guard's check of the pass before, and q_f) and one over the vertices, which sums q_f over
// its faces; M_v and sum_f A_f are the round's, summed in its first pass.
#include <algorithm>
#include <cmath>

#include "core/flows/normal_filtering.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

// The tangential relaxation of a folded face's vertices, as a share of the umbrella (eq. 3).
constexpr double kUnfoldStep = 0.5;

}  // namespace

void NormalFilterKernel::FitFaces(const Vec3* pos) {
  ForFaces([&](int32_t f) {
    const Triangle& t = graph_.faces[f];
    FitFace(f, normal_[f], FaceCross(pos, t), Centroid(pos, t), false, false);
  });
}

bool NormalFilterKernel::UpdateVertices(const StepContext& c, const Vec3* cur, int32_t n, int threads, bool round_start,
                                        bool check_start) {
  target_.resize(n);
  planes_.resize(n);
  damping_.assign(n, 0);
  const int32_t blocks = (n + kBlock - 1) / kBlock;
  capped_.assign(blocks, 0);
  moved_on_.assign(blocks, 0);
  const double lambda = c.lambda;
  ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
    const int32_t* const first = graph_.vertex_offsets.data();
    const int32_t* const faces = graph_.vertex_faces.data();
    const uint8_t* const state = state_.data();
    const Vec3* const q = q_.data();
    for (int32_t v = begin; v < end; ++v) {
      const Vec3 x = cur[v];
      if (check_start && !(target_[v] == x)) moved_on_[b] = 1;
      if (c.role[v] == kFixed) {
        target_[v] = x;
        continue;
      }
      Vec3 sum;
      bool folded = false;
      VertexPlanes& m = planes_[v];
      if (round_start) {
        m = {};
        for (int32_t k = first[v]; k < first[v + 1]; ++k) {
          const int32_t face = faces[k];
          if (state[face] == kNoNormal) continue;
          const Vec3 nf = normal_[face];
          const double a = area_[face];
          const Vec3 an = nf * a;
          m.xx += an.x * nf.x, m.xy += an.x * nf.y, m.xz += an.x * nf.z;
          m.yy += an.y * nf.y, m.yz += an.y * nf.z, m.zz += an.z * nf.z;
          m.weight += a;
          sum += q[face];
          folded |= state[face] == kOpposes;
        }
      } else {
        for (int32_t k = first[v]; k < first[v + 1]; ++k) {
          sum += q[faces[k]];  // zero for a face without normal
          folded |= state[faces[k]] == kOpposes;
        }
      }
      Vec3 f{sum.x - (m.xx * x.x + m.xy * x.y + m.xz * x.z), sum.y - (m.xy * x.x + m.yy * x.y + m.yz * x.z),
             sum.z - (m.xz * x.x + m.yz * x.y + m.zz * x.z)};
      if (m.weight > 0.0) f *= 1.0 / m.weight;
      // A folded face's vertices also move tangentially towards the centroid of their ring (the
      // umbrella of eq. 3 without its normal part): the projection alone keeps a fold.
      if (folded && c.role[v] == kFree && c.offsets[v + 1] > c.offsets[v]) {
        Vec3 normal;
        for (int32_t k = first[v]; k < first[v + 1]; ++k) {
          if (state[faces[k]] != kNoNormal) normal += normal_[faces[k]] * area_[faces[k]];
        }
        Vec3 centre;
        for (int32_t k = c.offsets[v]; k < c.offsets[v + 1]; ++k) centre += cur[c.ring[k]];
        const Vec3 u = centre * (1.0 / (c.offsets[v + 1] - c.offsets[v])) - x;
        const double len = Norm(normal);
        const Vec3 dir = len > 0.0 ? normal * (1.0 / len) : Vec3{};
        f += (u - dir * Dot(dir, u)) * kUnfoldStep;
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
  return std::find(moved_on_.begin(), moved_on_.end(), 1) == moved_on_.end();
}

// A vertex of a face that the moves would turn against its filtered normal moves half as far,
// then not at all, until no face turns. Every round decides from target_ as it stands, then
// writes it, so the result does not depend on the thread count; it ends because each round
// damps some vertex further and the undamped positions (cur) turn no face. The first round
// checks every face (and fits it in target_ for the next pass); later ones only the faces
// around the vertices damped in the round before.
void NormalFilterKernel::GuardOrientation(const Vec3* cur, int32_t n, int threads, bool terms) {
  const Vec3* const target = target_.data();
  const int32_t nf = static_cast<int32_t>(graph_.faces.size());
  next_state_.resize(nf);
  next_cosine_.resize(nf);
  // Fits face f to target_ for the next pass and tells whether the moves turned it.
  auto fit = [&](int32_t f) __attribute__((always_inline)) {
    const Triangle& t = graph_.faces[f];
    const Vec3 &p0 = target[t[0]], &p1 = target[t[1]], &p2 = target[t[2]];
    const Vec3 cross = Cross(p1 - p0, p2 - p0);
    const uint8_t was = state_[f];
    if (!terms) {  // the round's last pass: only whether it turned
      if (was == kAgrees) return !(Dot(cross, normal_[f]) > 0.0);
      return was == kOpposes && CosineTo(cross, normal_[f]) < cosine_[f];
    }
    const double cosine = FitFace(f, normal_[f], cross, (p0 + p1 + p2) * (1.0 / 3.0), true, was == kOpposes);
    return was == kAgrees ? next_state_[f] != kAgrees : was == kOpposes && cosine < cosine_[f];
  };
  auto turns = [&](int32_t f) {
    if (state_[f] == kNoNormal) return false;
    const Vec3 cross = FaceCross(target, graph_.faces[f]);
    return state_[f] == kAgrees ? !(Dot(cross, normal_[f]) > 0.0) : CosineTo(cross, normal_[f]) < cosine_[f];
  };
  auto movable = [&](int32_t v) { return damping_[v] < 2 && !(target_[v] == cur[v]); };
  turned_.resize((nf + kBlock - 1) / kBlock);
  refit_stamp_.resize(nf, -1);
  ForBlocks(nf, threads, [&](int32_t b, int32_t begin, int32_t end) {
    turned_[b].clear();
    for (int32_t f = begin; f < end; ++f) {
      if (fit(f)) turned_[b].push_back(f);
    }
  });
  // The movable corners of the turned faces, each once (the set, not its order, decides).
  stamp_.resize(n, 0);
  std::vector<int32_t> damp, around, refit;
  ++round_;
  for (const std::vector<int32_t>& list : turned_) {
    for (int32_t f : list) {
      for (int32_t v : graph_.faces[f]) {
        if (stamp_[v] == round_) continue;
        stamp_[v] = round_;
        if (movable(v)) damp.push_back(v);
      }
    }
  }
  while (!damp.empty()) {
    ++round_;
    around.clear();
    for (int32_t v : damp) {
      ++damping_[v];
      target_[v] = damping_[v] == 1 ? cur[v] + (target_[v] - cur[v]) * 0.5 : cur[v];
      for (int32_t k = graph_.vertex_offsets[v]; k < graph_.vertex_offsets[v + 1]; ++k) {
        const int32_t f = graph_.vertex_faces[k];
        if (refit_stamp_[f] != pass_) refit_stamp_[f] = pass_, refit.push_back(f);
        for (int32_t u : graph_.faces[f]) {
          if (stamp_[u] != round_) stamp_[u] = round_, around.push_back(u);
        }
      }
    }
    damp.clear();
    // Which of them a face of theirs now turns: each on its own, on all threads when many.
    const int32_t count = static_cast<int32_t>(around.size());
    damped_.resize(count);
    ForBlocks(count, count > kBlock ? threads : 1, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t i = begin; i < end; ++i) {
        const int32_t u = around[i];
        damped_[i] = 0;
        if (!movable(u)) continue;
        for (int32_t k = graph_.vertex_offsets[u]; k < graph_.vertex_offsets[u + 1]; ++k) {
          if (turns(graph_.vertex_faces[k])) {
            damped_[i] = 1;
            break;
          }
        }
      }
    });
    for (int32_t i = 0; i < count; ++i) {
      if (damped_[i]) damp.push_back(around[i]);
    }
  }
  if (!terms) return;              // the next pass starts a round: it fits the faces again
  for (int32_t f : refit) fit(f);  // faces whose corners the guard moved back
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
