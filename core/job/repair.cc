#include "core/job/repair.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "core/flows/flow_kernel.h"
#include "core/measure/folded_faces.h"
#include "core/measure/noise.h"
#include "core/normals.h"

namespace meshsmooth::job {

using flows::kBlock;
using flows::kCurve;
using flows::kFree;

FoldRepair::FoldRepair(const Topology& topo, const uint8_t* role, double h, int threads, const JobPolicy& policy)
    : topo_(topo),
      role_(role),
      h_(h),
      threads_(threads),
      policy_(policy),
      cos_fold_(FoldCosine(policy)),
      cos_rim_needle_(std::cos(policy.rim_needle_angle_deg * std::numbers::pi / 180.0)) {}

FoldRepair::Fold FoldRepair::Folded(const Vec3* pos, int32_t v) const {
  if (role_[v] == kCurve) return RimFolded(pos, v) ? kFolded : kNotFolded;
  if (role_[v] != kFree || topo_.kind[v] != VertexKind::kInterior) return kNotFolded;
  if (FanFolds(pos, topo_, v)) return kFanFolded;
  return ForFoldedEdges(pos, topo_, v, cos_fold_, [](int32_t) { return true; }) ? kFolded : kNotFolded;
}

bool FoldRepair::SlideToUnfold(const Vec3* pos, int32_t v, const Vec3& normal, Vec3& to) const {
  const int32_t first = topo_.ring_offsets[v], last = topo_.ring_offsets[v + 1];
  to = pos[v];
  for (int sweep = 0; sweep < policy_.unfold_sweeps; ++sweep) {
    bool unfolded = true;
    for (int32_t k = first; k < last; ++k) {
      const Vec3 a = pos[topo_.ring[k]], b = pos[topo_.ring[k + 1 < last ? k + 1 : first]];
      // Twice the projected area of face (to, a, b), Dot(Cross(a - to, b - to), normal), is
      // linear in `to` and grows along `rise` = normal x (b - a), whose squared length is that
      // of the far edge: a height of unfold_height |b - a| is twice the area unfold_height |rise|^2.
      const Vec3 rise = Cross(normal, b - a);
      const double edge2 = Dot(rise, rise);
      if (!(edge2 > 0.0)) continue;
      const double twice_area = Dot(Cross(a - to, b - to), normal);
      const double wanted = policy_.unfold_height * edge2;
      if (twice_area >= 0.5 * wanted) continue;
      unfolded = false;
      to += rise * ((wanted - twice_area) / edge2);
    }
    if (unfolded) return true;
  }
  return false;
}

bool FoldRepair::RimFolded(const Vec3* pos, int32_t v) const {
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

int64_t FoldRepair::Run(Vec3* pos) const {
  const int32_t n = topo_.num_vertices();
  // The folded vertices, found once over the mesh, then followed on their own (a round moves
  // only them, and only they are checked again): the repair costs nothing where nothing is
  // folded.
  std::vector<uint8_t> folded(n, 0);
  flows::ForBlocks(n, threads_, [&](int32_t, int32_t begin, int32_t end) {
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
  // fold_repair_reach_h h from there.
  std::vector<Vec3> origin(list.size()), moved(list.size());
  for (size_t i = 0; i < list.size(); ++i) origin[i] = pos[list[i]];
  const double reach = policy_.fold_repair_reach_h * h_, slide_reach = policy_.unfold_slide_h * h_;
  for (int round = 0; round < policy_.fold_repair_rounds && !list.empty(); ++round) {
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

double EnclosedVolume(const Vec3* pos, const Topology& topo, int threads) {
  // Each face (v, a, b) around v contributes v . (a x b) / 6, and is met at its three corners.
  // Around a closed ring the sum of (a - v) x (b - v) equals the sum of a x b, so the corner's
  // share is v . RingNormal(v), the ring walk the displacement and KeepVolume use too.
  const int32_t n = topo.num_vertices();
  std::vector<double> block_sum((n + kBlock - 1) / kBlock, 0.0);
  flows::ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
    double sum = 0.0;
    for (int32_t v = begin; v < end; ++v) sum += Dot(pos[v], RingNormal(topo, pos, v));
    block_sum[b] = sum;
  });
  double total = 0.0;
  for (double s : block_sum) total += s;
  return total / 18.0;
}

void RestoreVolume(Vec3* pos, const Topology& topo, const uint8_t* role, double h, int threads, double volume,
                   double max_offset_h) {
  const int32_t n = topo.num_vertices();
  std::vector<Vec3> unit(n);
  std::vector<double> block_rate((n + kBlock - 1) / kBlock, 0.0);
  // A few Newton steps on the common offset d: dV/dd = sum over the free vertices of
  // |RingNormal| / 6 (the gradient of the volume at v is RingNormal(v) / 6).
  for (int step = 0; step < 3; ++step) {
    flows::ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
      double rate = 0.0;
      for (int32_t v = begin; v < end; ++v) {
        unit[v] = {};
        if (role[v] != kFree || topo.kind[v] != VertexKind::kInterior) continue;
        const Vec3 normal = RingNormal(topo, pos, v);
        const double len = Norm(normal);
        if (!(len > 0.0) || !std::isfinite(len)) continue;
        unit[v] = normal * (1.0 / len);
        rate += len / 6.0;
      }
      block_rate[b] = rate;
    });
    double rate = 0.0;
    for (double r : block_rate) rate += r;
    const double gap = volume - EnclosedVolume(pos, topo, threads);
    if (!(rate > 0.0) || !std::isfinite(gap)) return;
    const double d = gap / rate;
    // A correction of more than a mean edge length is not a flow's shrinkage: leave it.
    if (!(std::abs(d) <= max_offset_h * h)) return;
    for (int32_t v = 0; v < n; ++v) pos[v] += unit[v] * d;
  }
}

double SurfaceArea(const std::vector<Vec3>& pos, const Mesh& mesh, const Topology& topo) {
  double area = 0.0;
  for (int32_t f : topo.faces) {
    const Triangle& t = mesh.triangles[f];
    area += 0.5 * Norm(Cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]));
  }
  return area;
}

void RemoveOutliers(Mesh& mesh, const Topology& topo, double h, double threshold_h, int rounds,
                    std::vector<uint8_t>& moved, int threads, const StopToken& stop, const uint8_t* keep,
                    int unfold_rounds, const NoiseParams& fit_params) {
  const int32_t n = topo.num_vertices();
  moved.resize(n, 0);
  if (!(h > 0.0) || !std::isfinite(h) || n == 0) return;
  if (threads <= 0) threads = omp_get_max_threads();
  std::vector<Vec3> target(n);
  std::vector<uint8_t> moves(n, 0);
  // The vertices to look at in a round: all in the first, then those within two rings of a
  // vertex the round before moved (no other fit has changed).
  std::vector<uint8_t> check(n, 1);
  for (int round = 0; round < rounds && !stop.Fired(); ++round) {
    // The outliers first, then each one's place from the other vertices around: a thrown
    // neighbour would tilt the plane (a ring with one vertex 2 h up leans by ~40 degrees) and
    // leave the vertex beside its place, with faces turned over.
#pragma omp parallel num_threads(threads) if (threads > 1 && n >= kMinParallelFits)
    {
      LocalFit fit(fit_params);
#pragma omp for schedule(static, 128)
      for (int32_t v = 0; v < n; ++v) {
        moves[v] = 0;
        const bool rim = topo.kind[v] == VertexKind::kBoundary;
        if (!check[v] || (topo.kind[v] != VertexKind::kInterior && !rim) || (keep != nullptr && keep[v] != 0)) continue;
        // A vertex without a fit (a boundary vertex's half ring, a ring too small) is judged by
        // its ring's median height.
        const std::optional<double> residual = rim ? std::nullopt : fit.ResidualH(mesh, topo, v, h);
        if (residual) {
          moves[v] = *residual > threshold_h;
        } else {
          const std::optional<double> height = fit.RingHeight(mesh.positions.data(), topo, v, nullptr);
          moves[v] = height && std::abs(*height) > threshold_h * h;
        }
      }
    }
#pragma omp parallel num_threads(threads) if (threads > 1 && n >= kMinParallelFits)
    {
      LocalFit fit(fit_params);
#pragma omp for schedule(static, 128)
      for (int32_t v = 0; v < n; ++v) {
        if (!moves[v]) continue;
        Vec3 axis;
        // A rim vertex's half ring along a plane its thrown neighbours do not lean.
        const std::optional<double> height =
            topo.kind[v] == VertexKind::kBoundary
                ? fit.RobustRingHeight(mesh.positions.data(), topo, v, h, moves.data(), &axis)
                : fit.RingHeight(mesh.positions.data(), topo, v, moves.data(), &axis);
        if (height)
          target[v] = mesh.positions[v] + axis * *height;
        else
          moves[v] = 0;
      }
    }
    bool any = false;
    std::fill(check.begin(), check.end(), 0);
    for (int32_t v = 0; v < n; ++v) {
      if (!moves[v]) continue;
      mesh.positions[v] = target[v];
      moved[v] = 1;
      any = true;
      check[v] = 1;
      for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) {
        const int32_t w = topo.ring[k];
        check[w] = 1;
        for (int32_t j = topo.ring_offsets[w]; j < topo.ring_offsets[w + 1]; ++j) check[topo.ring[j]] = 1;
      }
    }
    if (!any) break;
  }
  UnfoldFans(mesh, topo, unfold_rounds, moved, threads, stop, keep);
}

int64_t KeepNoMoreFolds(Vec3* pos, const Vec3* input, const Mesh& mesh, const Topology& topo, int max_rounds) {
  const FaceFolds folds(mesh, topo);
  const std::vector<uint8_t> before = folds.Folded(input);
  int64_t allowed = 0;
  for (uint8_t f : before) allowed += f;
  const int32_t n = topo.num_vertices();
  std::vector<uint8_t> back(n, 0);
  auto put_back = [&](int32_t v) {
    if (back[v] || pos[v] == input[v]) return;
    back[v] = 1;
    pos[v] = input[v];
  };
  for (int round = 0;; ++round) {
    const std::vector<uint8_t> after = folds.Folded(pos);
    int64_t count = 0;
    for (uint8_t f : after) count += f;
    if (count <= allowed) break;
    if (round == max_rounds) {
      for (int32_t v = 0; v < n; ++v) put_back(v);
      break;
    }
    for (size_t i = 0; i < after.size(); ++i) {
      if (!after[i] || before[i]) continue;
      const auto f = static_cast<int32_t>(i);
      for (int32_t v : folds.face(f)) put_back(v);
      for (int32_t g : folds.across(f)) {
        if (g < 0) continue;
        for (int32_t v : folds.face(g)) put_back(v);
      }
    }
  }
  int64_t count = 0;
  for (uint8_t b : back) count += b;
  return count;
}

bool FanFolds(const Vec3* pos, const Topology& topo, int32_t v) {
  const int32_t first = topo.ring_offsets[v], end = topo.ring_offsets[v + 1];
  const bool rim = topo.kind[v] == VertexKind::kBoundary;
  const int32_t faces = rim ? end - first - 1 : end - first;
  auto next = [&](int32_t k) { return k + 1 < end ? k + 1 : first; };
  Vec3 orientation;
  for (int32_t k = first; k < first + faces; ++k) {
    const Vec3 &a = pos[topo.ring[k]], &b = pos[topo.ring[next(k)]];
    orientation += rim ? Cross(a - pos[v], b - pos[v]) : Cross(a, b);
  }
  for (int32_t k = first; k < first + faces; ++k) {
    if (Dot(Cross(pos[topo.ring[k]] - pos[v], pos[topo.ring[next(k)]] - pos[v]), orientation) < 0.0) return true;
  }
  return false;
}

int64_t UnfoldFans(Mesh& mesh, const Topology& topo, int rounds, std::vector<uint8_t>& moved, int threads,
                   const StopToken& stop, const uint8_t* keep) {
  const int32_t n = topo.num_vertices();
  moved.resize(n, 0);
  if (threads <= 0) threads = omp_get_max_threads();
  std::vector<Vec3> target(n);
  std::vector<uint8_t> moves(n, 0);
  // The vertices to look at in a round: all in the first, then the last round's moves and their
  // rings (a fan depends on its vertex and its ring only).
  std::vector<uint8_t> check(n, 1);
  int64_t count = 0;
  for (int round = 0; round < rounds && !stop.Fired(); ++round) {
#pragma omp parallel for num_threads(threads) if (threads > 1 && n >= kMinParallelFits) schedule(static, 512)
    for (int32_t v = 0; v < n; ++v) {
      moves[v] = 0;
      const bool rim = topo.kind[v] == VertexKind::kBoundary;
      if (!check[v] || (topo.kind[v] != VertexKind::kInterior && !rim) || (keep != nullptr && keep[v] != 0)) continue;
      if (topo.valence(v) < 3 || !FanFolds(mesh.positions.data(), topo, v)) continue;
      const int32_t first = topo.ring_offsets[v], end = topo.ring_offsets[v + 1];
      Vec3 centre;
      if (rim) {
        centre = (mesh.positions[topo.ring[first]] + mesh.positions[topo.ring[end - 1]]) * 0.5;
      } else {
        for (int32_t k = first; k < end; ++k) centre += mesh.positions[topo.ring[k]];
        centre *= 1.0 / static_cast<double>(end - first);
      }
      target[v] = centre;
      moves[v] = 1;
    }
    bool any = false;
    std::fill(check.begin(), check.end(), 0);
    for (int32_t v = 0; v < n; ++v) {
      if (!moves[v]) continue;
      mesh.positions[v] = target[v];
      count += !moved[v];
      moved[v] = 1;
      any = true;
      check[v] = 1;
      for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) check[topo.ring[k]] = 1;
    }
    if (!any) break;
  }
  return count;
}

}  // namespace meshsmooth::job
