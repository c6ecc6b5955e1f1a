#include "core/flows/normal_filtering.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_format.h"
#include "core/flows/lanes.h"
#include "core/flows/reorder.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

// The union of three ascending lists of faces, each face once, ascending, into `out` (null:
// only counted); returns its size.
int32_t MergeThree(const int32_t* a, const int32_t* a_end, const int32_t* b, const int32_t* b_end, const int32_t* c,
                   const int32_t* c_end, int32_t* out) {
  int32_t count = 0, last = -1;
  constexpr int32_t kEnd = INT32_MAX;
  for (;;) {
    const int32_t x = a != a_end ? *a : kEnd, y = b != b_end ? *b : kEnd, z = c != c_end ? *c : kEnd;
    const int32_t m = std::min(x, std::min(y, z));
    if (m == kEnd) return count;
    a += x == m, b += y == m, c += z == m;
    if (m == last) continue;
    if (out != nullptr) out[count] = m;
    ++count;
    last = m;
  }
}

// The face other than f holding both a and b, or -1 when there is none or more than one.
int32_t FaceAcross(const FaceGraph& g, int32_t f, int32_t a, int32_t b) {
  const int32_t *p = &g.vertex_faces[g.vertex_offsets[a]], *p_end = &g.vertex_faces[g.vertex_offsets[a + 1]];
  const int32_t *q = &g.vertex_faces[g.vertex_offsets[b]], *q_end = &g.vertex_faces[g.vertex_offsets[b + 1]];
  int32_t other = -1, count = 0;
  while (p != p_end && q != q_end) {
    if (*p < *q) {
      ++p;
    } else if (*q < *p) {
      ++q;
    } else {
      if (*p != f) other = *p, ++count;
      ++p, ++q;
    }
  }
  return count == 1 ? other : -1;
}

// The faces sharing a vertex with face f (f included), ascending, into `out` (null: only
// counted); returns their number. vertex_faces lists each vertex's faces ascending.
int32_t NeighbourFaces(const FaceGraph& g, int32_t f, int32_t* out) {
  const Triangle& t = g.faces[f];
  const int32_t* vf = g.vertex_faces.data();
  const int32_t* o = g.vertex_offsets.data();
  return MergeThree(vf + o[t[0]], vf + o[t[0] + 1], vf + o[t[1]], vf + o[t[1] + 1], vf + o[t[2]], vf + o[t[2] + 1],
                    out);
}

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
  // The faces in Morton order of their centroids: neighbouring faces then sit close in memory
  // whatever the mesh's own order, and the order (so every sum) does not depend on how the
  // vertices are numbered.
  {
    std::vector<Vec3> centroid(nf);
    for (int32_t f = 0; f < nf; ++f) centroid[f] = Centroid(mesh.positions.data(), mesh.triangles[topo.faces[f]]);
    const std::vector<int32_t> order = MortonOrder(centroid, threads);
    g.faces.resize(nf);
    for (int32_t f = 0; f < nf; ++f) g.faces[f] = mesh.triangles[topo.faces[order[f]]];
  }

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
    for (int32_t f = begin; f < end; ++f) g.offsets[f + 1] = NeighbourFaces(g, f, nullptr);
  });
  for (int32_t f = 0; f < nf; ++f) g.offsets[f + 1] += g.offsets[f];
  g.neighbours.resize(g.offsets[nf]);
  g.across.resize(nf);
  std::vector<double> distance_sum(nf);
  std::vector<int32_t> distance_count(nf);
  const Vec3* pos = mesh.positions.data();
  ForBlocks(nf, threads, [&](int32_t, int32_t begin, int32_t end) {
    for (int32_t f = begin; f < end; ++f) {
      NeighbourFaces(g, f, &g.neighbours[g.offsets[f]]);
      const Triangle& t = g.faces[f];
      for (int e = 0; e < 3; ++e) {
        const int32_t other = FaceAcross(g, f, t[e], t[(e + 1) % 3]);
        g.across[f][e] = other;
        if (other > f) {
          distance_sum[f] += Norm(Centroid(pos, t) - Centroid(pos, g.faces[other]));
          ++distance_count[f];
        }
      }
    }
  });
  double sum = 0.0;
  int64_t pairs = 0;
  for (int32_t f = 0; f < nf; ++f) sum += distance_sum[f], pairs += distance_count[f];
  g.mean_centroid_distance = pairs > 0 ? sum / static_cast<double>(pairs) : 0.0;
  return g;
}

void NormalFilterKernel::Bind(const Mesh& mesh, const Topology& topo, int threads) {
  threads_ = threads;
  graph_ = BuildFaceGraph(mesh, topo, threads);
  inv_two_sigma_r2_ = 1.0 / (2.0 * p_.sigma_range * p_.sigma_range);
  const double sigma_s = p_.sigma_spatial * graph_.mean_centroid_distance;
  inv_two_sigma_s2_ = sigma_s > 0.0 ? 1.0 / (2.0 * sigma_s * sigma_s) : 0.0;
}

void NormalFilterKernel::ComputeGeometry(const Vec3* pos) {
  const int32_t nf = static_cast<int32_t>(graph_.faces.size());
  // Buffers kept from round to round: fresh ones would cost a page fault per 4 KiB each round.
  std::vector<Vec3>& centroid = centroid_;
  normal_.resize(nf);  // first each face's own unit normal, then (below) what the filter starts from
  weighted_.resize(nf);
  centroid.resize(nf);
  cross_.resize(nf);
  area_.resize(nf);
  ForFaces([&](int32_t f) {
    const Triangle& t = graph_.faces[f];
    const Vec3 ab = pos[t[1]] - pos[t[0]], ac = pos[t[2]] - pos[t[0]];
    const Vec3 cross = Cross(ab, ac);
    const double len = Norm(cross);
    // A face without area (or a needle whose cross product is all rounding) has no normal.
    const bool ok = 1e-12 * (SquaredNorm(ab) + SquaredNorm(ac)) < len && std::isfinite(len);
    normal_[f] = ok ? cross * (1.0 / len) : Vec3{};
    cross_[f] = cross;
    area_[f] = ok ? 0.5 * len : 0.0;
    weighted_[f] = normal_[f] * area_[f];
    centroid[f] = Centroid(pos, t);
  });
  // Each face reads its own normal_ entry before it writes it, and only weighted_ of the others.
  ForFaces([&](int32_t i) {
    const Vec3 raw = normal_[i];
    Vec3 around;
    for (int32_t k = graph_.offsets[i]; k < graph_.offsets[i + 1]; ++k) {
      const int32_t j = graph_.neighbours[k];
      around += weighted_[j];
    }
    around -= weighted_[i];
    // Noise folds thin faces over: a folded face's own normal would keep it folded, since the
    // range weight shuts out every neighbour on the other side; it takes its neighbours'.
    const double len = Norm(around);
    normal_[i] = area_[i] > 0.0 && Dot(raw, around) < 0.0 && len > 0.0 ? around * (1.0 / len) : raw;
  });
}

void NormalFilterKernel::Filter(const std::vector<Vec3>& g, std::vector<Vec3>& out) {
  const int32_t nf = static_cast<int32_t>(graph_.faces.size());
  const bool separate = &g != &normal_;  // guidance normals: the filtered normals are another array
  ForBlocks(nf, threads_, [&](int32_t, int32_t begin, int32_t end) {
    RunWithIsa(
        isa_, [&](auto width) __attribute__((always_inline)) {
          constexpr int W = decltype(width)::value;
          using V = typename VertexLanesOf<W>::type;
          using I = typename IndexLanesOf<W>::type;
          const double* const centroid = &centroid_[0].x;
          const double* const guide = &g[0].x;
          const double* const normal = &normal_[0].x;
          const double* const area = area_.data();
          const int32_t* const offsets = graph_.offsets.data();
          const int32_t* const neighbours = graph_.neighbours.data();
          const V zero = V{} + 0.0;
          I lane;
          for (int l = 0; l < W; ++l) lane[l] = l;  // a constant
          alignas(8 * W) double sum_of[3][W];
          // W faces at a time, one per lane; each lane sums its own entries in order, so its bits are
          // those of the face summed alone, whatever W. A lane with fewer entries than the batch's
          // most adds zeros (a face past `end` repeats the batch's first).
          for (int32_t first = begin; first < end; first += W) {
            const int32_t count = std::min<int32_t>(W, end - first);
            const I self = lane < count ? first + lane : first + I{};
            I at, stop;
            for (int l = 0; l < W; ++l) at[l] = offsets[self[l]], stop[l] = offsets[self[l] + 1];
            int32_t most = 0;
            for (int l = 0; l < W; ++l) most = std::max(most, stop[l] - at[l]);
            const I self3 = 3 * self;
            V cix, ciy, ciz, gix, giy, giz;
            GatherXyzLanes<W>(centroid, self3, cix, ciy, ciz);
            GatherXyzLanes<W>(guide, self3, gix, giy, giz);
            const V entries = __builtin_convertvector(stop - at, V);
            V sx = zero, sy = zero, sz = zero;
            for (int32_t k = 0; k < most; ++k, at += 1) {
              const auto live = at < stop;
              const I j = GatherIndexLanes<W>(neighbours, at, live, self);
              const I j3 = 3 * j;
              V cx, cy, cz, gx, gy, gz;
              GatherXyzLanes<W>(centroid, j3, cx, cy, cz);
              GatherXyzLanes<W>(guide, j3, gx, gy, gz);
              V nx = gx, ny = gy, nz = gz;
              if (separate) GatherXyzLanes<W>(normal, j3, nx, ny, nz);
              const V dcx = cix - cx, dcy = ciy - cy, dcz = ciz - cz;
              const V dgx = gix - gx, dgy = giy - gy, dgz = giz - gz;
              // W_s W_r as one exponential.
              const V x = (dcx * dcx + dcy * dcy + dcz * dcz) * inv_two_sigma_s2_ +
                          (dgx * dgx + dgy * dgy + dgz * dgz) * inv_two_sigma_r2_;
              const V w = GatherLanes<W>(area, j) * NegExpLanes<W>(x);
              const V weight = zero + k < entries ? w : zero;
              sx += nx * weight, sy += ny * weight, sz += nz * weight;
            }
            std::memcpy(sum_of[0], &sx, sizeof sx);
            std::memcpy(sum_of[1], &sy, sizeof sy);
            std::memcpy(sum_of[2], &sz, sizeof sz);
            for (int32_t l = 0; l < count; ++l) {
              const int32_t i = first + l;
              const Vec3 sum{sum_of[0][l], sum_of[1][l], sum_of[2][l]};
              const double len = Norm(sum);
              out[i] = area_[i] > 0.0 && len > 0.0 && std::isfinite(len) ? sum * (1.0 / len) : normal_[i];
              if (fit_) FitFace(i, out[i], cross_[i], centroid_[i], false, false);
            }
          }
          return BlockStats{};
        });
  });
}

void NormalFilterKernel::Prepare(const StepContext& c, const Vec3* cur, int32_t n, int threads) {
  isa_ = c.isa;
  const int pass = pass_++ % passes();
  if (pass == 0) {  // the vertex passes of a round keep its normals
    ComputeGeometry(cur);
    filtered_.resize(normal_.size());
    state_.resize(normal_.size());
    cosine_.resize(normal_.size());
    q_.resize(normal_.size());
    for (int k = 0; k < p_.normal_iterations; ++k) {
      fit_ = k + 1 == p_.normal_iterations;  // FitFace reads normal_: written after the swap below
      FilterOnce(filtered_);
      normal_.swap(filtered_);
    }
    fit_ = false;
  }
  if (!UpdateVertices(c, cur, n, threads, pass == 0, pass > 0)) {
    // `cur` is not where the pass before left the vertices (target_): the faces are fitted to it.
    FitFaces(cur);
    UpdateVertices(c, cur, n, threads, false, false);
  }
  GuardOrientation(cur, n, threads, pass + 1 < passes());
}

}  // namespace meshsmooth::flows
