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

void NormalFilterKernel::Prepare(const StepContext& /*c*/, const Vec3* cur, int32_t /*n*/, int /*threads*/) {
  if (pass_++ % passes() != 0) return;  // the vertex passes of a round keep its normals
  ComputeGeometry(cur);
  std::vector<Vec3> filtered(normal_.size());
  for (int k = 0; k < p_.normal_iterations; ++k) {
    FilterOnce(filtered);
    normal_.swap(filtered);
  }
}

BlockStats NormalFilterKernel::Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin,
                                    int32_t end) const {
  const double lambda = c.lambda, max_step_sq = c.max_step_sq;
  double max_sq = 0.0, sum = 0.0;
  int64_t moved = 0, movable = 0, capped = 0;
  for (int32_t v = begin; v < end; ++v) {
    if (c.role[v] == kFixed) {
      next[v] = cur[v];
      continue;
    }
    Vec3 f;
    int32_t count = 0;
    for (int32_t k = graph_.vertex_offsets[v]; k < graph_.vertex_offsets[v + 1]; ++k) {
      const int32_t face = graph_.vertex_faces[k];
      const Vec3& nf = normal_[face];
      if (nf.x == 0.0 && nf.y == 0.0 && nf.z == 0.0) continue;
      f += nf * Dot(nf, Centroid(cur, graph_.faces[face]) - cur[v]);
      ++count;
    }
    if (count > 0) f *= 1.0 / count;
    if (c.threshold != nullptr) f = Threshold(f, c.threshold[v]);
    Vec3 step = f * lambda;
    const double len2 = SquaredNorm(step);
    if (len2 > max_step_sq) {
      step *= std::sqrt(max_step_sq / len2);
      ++capped;
    }
    next[v] = cur[v] + step;
    const double d2 = SquaredNorm(step);
    max_sq = std::max(max_sq, d2);
    sum += std::sqrt(d2);
    moved += d2 > 0.0;
    ++movable;
  }
  return FinishBlock(max_sq, sum, moved, movable, capped);
}

}  // namespace meshsmooth::flows
