#include "core/flows/normal_filtering.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_format.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

// The faces sharing a vertex with face f (f included), ascending, into `out`.
void NeighbourFaces(const FaceGraph& g, int32_t f, std::vector<int32_t>& out) {
  out.clear();
  for (int32_t v : g.faces[f]) {
    out.insert(out.end(), g.vertex_faces.begin() + g.vertex_offsets[v], g.vertex_faces.begin() + g.vertex_offsets[v + 1]);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

bool HasVertex(const Triangle& t, int32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

Vec3 Centroid(const Vec3* pos, const Triangle& t) { return (pos[t[0]] + pos[t[1]] + pos[t[2]]) * (1.0 / 3.0); }

// The tangential relaxation of a folded face's vertices, as a share of the umbrella (eq. 3).
constexpr double kUnfoldStep = 0.5;

}  // namespace

absl::Status ValidateNormalFilter(const FlowParams& p, double /*step*/) {
  const NormalFilterParams& q = p.normal_filter;
  if (q.normal_iterations < 1 || q.normal_iterations > 100) {
    return absl::InvalidArgumentError(
        absl::StrFormat("normal_filter.normal_iterations must be in 1..100, got %d", q.normal_iterations));
  }
  if (q.vertex_iterations < 1 || q.vertex_iterations > 100) {
    return absl::InvalidArgumentError(
        absl::StrFormat("normal_filter.vertex_iterations must be in 1..100, got %d", q.vertex_iterations));
  }
  if (!(q.sigma_spatial > 0.0) || !(q.sigma_spatial <= 10.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("normal_filter.sigma_spatial must be in (0, 10], got %g", q.sigma_spatial));
  }
  if (!(q.sigma_range > 0.0) || !(q.sigma_range <= 2.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("normal_filter.sigma_range must be in (0, 2], got %g", q.sigma_range));
  }
  return absl::OkStatus();
}

FaceGraph BuildFaceGraph(const Mesh& mesh, const Topology& topo, int threads) {
  FaceGraph g;
  const int32_t n = mesh.num_vertices();
  const int32_t nf = static_cast<int32_t>(topo.faces.size());
  g.faces.reserve(nf);
  for (int32_t f : topo.faces) g.faces.push_back(mesh.triangles[f]);

  g.vertex_offsets.assign(static_cast<size_t>(n) + 1, 0);
  for (const Triangle& t : g.faces) {
    for (int32_t v : t) ++g.vertex_offsets[v + 1];
  }
  for (int32_t v = 0; v < n; ++v) g.vertex_offsets[v + 1] += g.vertex_offsets[v];
  g.vertex_faces.resize(g.vertex_offsets[n]);
  {
    std::vector<int32_t> at(g.vertex_offsets.begin(), g.vertex_offsets.end() - 1);
    for (int32_t f = 0; f < nf; ++f) {
      for (int32_t v : g.faces[f]) g.vertex_faces[at[v]++] = f;
    }
  }

  // Neighbourhoods in two passes (sizes, then entries), each face on its own.
  g.offsets.assign(static_cast<size_t>(nf) + 1, 0);
  ForBlocks(nf, threads, [&](int32_t, int32_t begin, int32_t end) {
    std::vector<int32_t> around;
    for (int32_t f = begin; f < end; ++f) {
      NeighbourFaces(g, f, around);
      g.offsets[f + 1] = static_cast<int32_t>(around.size());
    }
  });
  for (int32_t f = 0; f < nf; ++f) g.offsets[f + 1] += g.offsets[f];
  g.neighbours.resize(g.offsets[nf]);
  g.across.assign(nf, {-1, -1, -1});
  ForBlocks(nf, threads, [&](int32_t, int32_t begin, int32_t end) {
    std::vector<int32_t> around;
    for (int32_t f = begin; f < end; ++f) {
      NeighbourFaces(g, f, around);
      std::copy(around.begin(), around.end(), g.neighbours.begin() + g.offsets[f]);
      const Triangle& t = g.faces[f];
      for (int e = 0; e < 3; ++e) {
        const int32_t a = t[e], b = t[(e + 1) % 3];
        int32_t other = -1, count = 0;
        for (int32_t k = g.vertex_offsets[a]; k < g.vertex_offsets[a + 1]; ++k) {
          const int32_t h = g.vertex_faces[k];
          if (h != f && HasVertex(g.faces[h], b)) other = h, ++count;
        }
        g.across[f][e] = count == 1 ? other : -1;
      }
    }
  });

  double sum = 0.0;
  int64_t pairs = 0;
  const Vec3* pos = mesh.positions.data();
  for (int32_t f = 0; f < nf; ++f) {
    for (int32_t other : g.across[f]) {
      if (other > f) {
        sum += Norm(Centroid(pos, g.faces[f]) - Centroid(pos, g.faces[other]));
        ++pairs;
      }
    }
  }
  g.mean_centroid_distance = pairs > 0 ? sum / static_cast<double>(pairs) : 0.0;
  return g;
}

void NormalFilterKernel::Bind(const Mesh& mesh, const Topology& topo, int threads) {
  threads_ = threads;
  graph_ = BuildFaceGraph(mesh, topo, threads);
  inv_two_sigma_r2_ = 1.0 / (2.0 * p_.sigma_range * p_.sigma_range);
}

void NormalFilterKernel::ComputeGeometry(const Vec3* pos) {
  const int32_t nf = static_cast<int32_t>(graph_.faces.size());
  normal_.resize(nf);
  area_.resize(nf);
  std::vector<Vec3> centroid(nf);
  ForFaces([&](int32_t f) {
    const Triangle& t = graph_.faces[f];
    const Vec3 ab = pos[t[1]] - pos[t[0]], ac = pos[t[2]] - pos[t[0]];
    const Vec3 cross = Cross(ab, ac);
    const double len = Norm(cross);
    // A face without area (or a needle whose cross product is all rounding) has no normal.
    const bool ok = 1e-12 * (SquaredNorm(ab) + SquaredNorm(ac)) < len && std::isfinite(len);
    normal_[f] = ok ? cross * (1.0 / len) : Vec3{};
    area_[f] = ok ? 0.5 * len : 0.0;
    centroid[f] = Centroid(pos, t);
  });
  const double sigma_s = p_.sigma_spatial * graph_.mean_centroid_distance;
  const double inv_two_sigma_s2 = sigma_s > 0.0 ? 1.0 / (2.0 * sigma_s * sigma_s) : 0.0;
  spatial_.resize(graph_.neighbours.size());
  ForFaces([&](int32_t i) {
    for (int32_t k = graph_.offsets[i]; k < graph_.offsets[i + 1]; ++k) {
      const int32_t j = graph_.neighbours[k];
      spatial_[k] = area_[j] * std::exp(-SquaredNorm(centroid[i] - centroid[j]) * inv_two_sigma_s2);
    }
  });
}

Vec3 NormalFilterKernel::FilteredNormal(int32_t i, const std::vector<Vec3>& g) const {
  if (area_[i] == 0.0) return normal_[i];
  Vec3 sum;
  for (int32_t k = graph_.offsets[i]; k < graph_.offsets[i + 1]; ++k) {
    const int32_t j = graph_.neighbours[k];
    const double w = spatial_[k] * std::exp(-SquaredNorm(g[i] - g[j]) * inv_two_sigma_r2_);
    sum += normal_[j] * w;
  }
  const double len = Norm(sum);
  return len > 0.0 && std::isfinite(len) ? sum * (1.0 / len) : normal_[i];
}

void NormalFilterKernel::OrientOutliers() {
  std::vector<Vec3> oriented(normal_.size());
  ForFaces([&](int32_t i) {
    oriented[i] = normal_[i];
    if (area_[i] == 0.0) return;
    Vec3 around;
    for (int32_t k = graph_.offsets[i]; k < graph_.offsets[i + 1]; ++k) {
      const int32_t j = graph_.neighbours[k];
      if (j != i) around += normal_[j] * area_[j];
    }
    // Noise folds thin faces over: their own normal would keep them folded, since the range
    // weight shuts out every neighbour on the other side.
    const double len = Norm(around);
    if (Dot(normal_[i], around) < 0.0 && len > 0.0) oriented[i] = around * (1.0 / len);
  });
  normal_.swap(oriented);
}

void NormalFilterKernel::Prepare(const StepContext& c, const Vec3* cur, int32_t n, int threads) {
  if (pass_++ % passes() == 0) {  // the vertex passes of a round keep its normals
    ComputeGeometry(cur);
    OrientOutliers();
    std::vector<Vec3> filtered(normal_.size());
    for (int k = 0; k < p_.normal_iterations; ++k) {
      FilterOnce(filtered);
      normal_.swap(filtered);
    }
  }
  UpdateVertices(c, cur, n, threads);
}

namespace {

// A face's orientation against its filtered normal in a pass's positions.
enum FaceState : uint8_t {
  kNoNormal = 0,  // no filtered normal (no area at the round's start)
  kAgrees = 1,    // its normal . the filtered normal > 0: a pass keeps it so
  kOpposes = 2,   // folded: its vertices relax tangentially
};

Vec3 FaceCross(const Vec3* pos, const Triangle& t) { return Cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]); }

}  // namespace

void NormalFilterKernel::UpdateVertices(const StepContext& c, const Vec3* cur, int32_t n, int threads) {
  const int32_t nf = static_cast<int32_t>(graph_.faces.size());
  offset_.resize(nf);
  state_.resize(nf);
  ForFaces([&](int32_t f) {
    const Triangle& t = graph_.faces[f];
    const Vec3& nf_ = normal_[f];
    offset_[f] = Dot(nf_, Centroid(cur, t));
    state_[f] = area_[f] == 0.0 ? kNoNormal : Dot(FaceCross(cur, t), nf_) > 0.0 ? kAgrees : kOpposes;
  });
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
        const Vec3& nf_ = normal_[face];
        const double a = area_[face];
        f += nf_ * (a * (offset_[face] - Dot(nf_, x)));
        normal += nf_ * a;
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
  // The guard: a vertex of a face that the moves would turn against its filtered normal moves
  // half as far, then not at all, until no face turns. Each round reads target_ and then
  // writes it, so the result does not depend on the thread count; it ends because every round
  // damps at least one vertex further and the undamped positions (cur) turn no face.
  std::vector<uint8_t> damp_more(n);
  std::vector<int32_t> damped(blocks);
  for (;;) {
    ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
      int32_t count = 0;
      for (int32_t v = begin; v < end; ++v) {
        damp_more[v] = 0;
        if (damping_[v] == 2 || target_[v] == cur[v]) continue;
        for (int32_t k = graph_.vertex_offsets[v]; k < graph_.vertex_offsets[v + 1]; ++k) {
          const int32_t face = graph_.vertex_faces[k];
          if (state_[face] == kAgrees && !(Dot(FaceCross(target_.data(), graph_.faces[face]), normal_[face]) > 0.0)) {
            damp_more[v] = 1;
            ++count;
            break;
          }
        }
      }
      damped[b] = count;
    });
    if (std::all_of(damped.begin(), damped.end(), [](int32_t d) { return d == 0; })) break;
    ForBlocks(n, threads, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) {
        if (!damp_more[v]) continue;
        ++damping_[v];
        target_[v] = damping_[v] == 1 ? cur[v] + (target_[v] - cur[v]) * 0.5 : cur[v];
      }
    });
  }
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
