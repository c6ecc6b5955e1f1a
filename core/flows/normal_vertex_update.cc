// The vertex update of the normal-filtering flows (normal_filtering.h) and its guards against
// folded faces; docs/normal-filtering.md ("The vertex update", "Folded faces") gives the
// equations and why each guard is there.
//
// A pass is one loop over the faces and one over the vertices. The face loop fits each face to
// the pass's positions (the guard's check of the pass before) and writes its term of the update
// at each corner into that corner's entry of the vertex's face list; each vertex then sums its
// own entries, contiguous and in ascending face order, with no gather.
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

namespace {

// Writes the update's terms of a face (corners t at p0, p1, p2; filtered normal n, area a, plane
// offset `offset`, FaceState `state`) to its corners' entries: what UpdateVertices sums.
__attribute__((always_inline)) inline void WriteTerms(const std::array<int32_t, 3>& entry, const Vec3& p0,
                                                      const Vec3& p1, const Vec3& p2, const Vec3& n, double a,
                                                      double offset, uint8_t state, NormalFilterKernel::Term* term) {
  if (state == kNoNormal) {
    for (int32_t e : entry) term[e] = {};
    return;
  }
  const double signed_area = state == kOpposes ? -a : a;
  term[entry[0]] = {n * (a * (offset - Dot(n, p0))), signed_area};
  term[entry[1]] = {n * (a * (offset - Dot(n, p1))), signed_area};
  term[entry[2]] = {n * (a * (offset - Dot(n, p2))), signed_area};
}

}  // namespace

void NormalFilterKernel::FitFaces(const Vec3* pos) {
  const int32_t nf = static_cast<int32_t>(graph_.faces.size());
  state_.resize(nf);
  cosine_.resize(nf);
  term_.resize(graph_.vertex_faces.size());
  ForBlocks(nf, threads_, [&](int32_t, int32_t begin, int32_t end) {
    const Triangle* const faces = graph_.faces.data();
    for (int32_t f = begin; f < end; ++f) {
      const Triangle& t = faces[f];
      const Vec3 &p0 = pos[t[0]], &p1 = pos[t[1]], &p2 = pos[t[2]];
      const Vec3 n = normal_[f];
      const double a = area_[f];
      const Vec3 cross = Cross(p1 - p0, p2 - p0);
      const double offset = Dot(n, (p0 + p1 + p2) * (1.0 / 3.0));
      const uint8_t state = StateOf(a, cross, n);
      state_[f] = state;
      if (state == kOpposes) cosine_[f] = CosineTo(cross, n);  // read for folded faces only
      WriteTerms(graph_.corner_entry[f], p0, p1, p2, n, a, offset, state, term_.data());
    }
  });
}

bool NormalFilterKernel::UpdateVertices(const StepContext& c, const Vec3* cur, int32_t n, int threads,
                                        bool check_start) {
  target_.resize(n);
  damping_.assign(n, 0);
  const int32_t blocks = (n + kBlock - 1) / kBlock;
  capped_.assign(blocks, 0);
  moved_on_.assign(blocks, 0);
  const double lambda = c.lambda;
  ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
    const Term* const term = term_.data();
    const int32_t* const first = graph_.vertex_offsets.data();
    for (int32_t v = begin; v < end; ++v) {
      const Vec3 x = cur[v];
      if (check_start && !(target_[v] == x)) moved_on_[b] = 1;
      if (c.role[v] == kFixed) {
        target_[v] = x;
        continue;
      }
      // The sum over the faces in ascending order; a face without normal adds zeros.
      Vec3 f;
      double weight = 0.0;
      bool folded = false;
      for (int32_t k = first[v]; k < first[v + 1]; ++k) {
        f += term[k].move;
        weight += std::fabs(term[k].area);
        folded |= term[k].area < 0.0;
      }
      if (weight > 0.0) f *= 1.0 / weight;
      // A folded face's vertices also move tangentially towards the centroid of their ring (the
      // umbrella of eq. 3 without its normal part): the projection alone keeps a fold.
      if (folded && c.role[v] == kFree && c.offsets[v + 1] > c.offsets[v]) {
        Vec3 normal;
        for (int32_t k = first[v]; k < first[v + 1]; ++k) {
          const int32_t face = graph_.vertex_faces[k];
          if (state_[face] != kNoNormal) normal += normal_[face] * area_[face];
        }
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
  // Fits face f to target_ (its state and terms for the next pass) and tells whether the moves
  // turned it. A face's cosine is read only while it is folded: now (state_) or in the next pass
  // (next_state_); the square root is skipped for the others, whose entry is not written.
  auto fit = [&](int32_t f) __attribute__((always_inline)) {
    const Triangle& t = graph_.faces[f];
    const Vec3 &p0 = target[t[0]], &p1 = target[t[1]], &p2 = target[t[2]];
    const Vec3 nrm = normal_[f];
    const double a = area_[f];
    const Vec3 cross = Cross(p1 - p0, p2 - p0);
    const uint8_t was = state_[f], state = StateOf(a, cross, nrm);
    next_state_[f] = state;
    bool turned = was == kAgrees && state != kAgrees;
    if (state == kOpposes || was == kOpposes) {
      const double cosine = CosineTo(cross, nrm);
      next_cosine_[f] = cosine;
      turned |= was == kOpposes && cosine < cosine_[f];
    }
    if (terms) {
      WriteTerms(graph_.corner_entry[f], p0, p1, p2, nrm, a, Dot(nrm, (p0 + p1 + p2) * (1.0 / 3.0)), state,
                 term_.data());
    }
    return turned;
  };
  auto turns = [&](int32_t f) {
    if (state_[f] == kNoNormal) return false;
    const Vec3 cross = FaceCross(target, graph_.faces[f]);
    return state_[f] == kAgrees ? !(Dot(cross, normal_[f]) > 0.0) : CosineTo(cross, normal_[f]) < cosine_[f];
  };
  auto movable = [&](int32_t v) { return damping_[v] < 2 && !(target_[v] == cur[v]); };
  turned_.resize((nf + kBlock - 1) / kBlock);
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
