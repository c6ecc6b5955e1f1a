#include "core/features/ridges.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

namespace meshsmooth {
namespace {

constexpr int32_t kParallelMin = 4096;  // below this the OpenMP team costs more than the loop

// The values the classifier compares: at a vertex with an estimate, the mean of kmax (kmin)
// over it and its neighbours that have one; at a vertex without (boundary, non-manifold,
// degenerate), the mean over its neighbours that have one, so that the vertices next to it can
// still be compared along their curvature lines. known[v] is 0 where neither exists. The mean
// is the estimate's noise filter: on the Delaunay triangulation of random points the per-vertex
// estimate scatters by a few percent, as much as kmax falls within two edges of a crest, and
// without it a band of vertices along each crest came out as ridges (precision 0.56 on the
// cosine sheet of CurvatureMeshesTest; 1.0 with it).
// Per vertex, the compared kmax, kmin side by side (NaN where unknown, never returned to the
// caller): one cache miss per neighbour rather than one per array.
struct Compared {
  double k[2] = {0.0, 0.0};  // kmax, kmin
  bool known() const { return !std::isnan(k[0]); }
};

std::vector<Compared> RingMeans(const Topology& topo, const CurvatureField& f) {
  const int32_t n = topo.num_vertices();
  constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::array<double, 2>> k(n);
  // Each loop reads what the one before wrote and writes only v's entries: the result does
  // not depend on the thread count.
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int32_t v = 0; v < n; ++v) {
    k[v] = f.valid[v] ? std::array<double, 2>{f.kmax[v], f.kmin[v]} : std::array<double, 2>{kUnknown, kUnknown};
  }
  std::vector<Compared> out(n);
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int32_t v = 0; v < n; ++v) {
    double kmax = 0.0, kmin = 0.0;
    int32_t count = 0;
    if (!std::isnan(k[v][0])) {
      kmax = k[v][0];
      kmin = k[v][1];
      count = 1;
    }
    for (int32_t i = topo.ring_offsets[v]; i < topo.ring_offsets[v + 1]; ++i) {
      const std::array<double, 2>& kq = k[topo.ring[i]];
      if (std::isnan(kq[0])) continue;
      kmax += kq[0];
      kmin += kq[1];
      ++count;
    }
    if (count == 0) {
      out[v].k[0] = out[v].k[1] = kUnknown;
    } else {
      out[v].k[0] = kmax / count;
      out[v].k[1] = kmin / count;
    }
  }
  return out;
}

// True when values[v] * sign is strictly above its linear interpolation at both points where
// the plane through P spanned by the normal and `dir` cuts the closed one-ring polygon (the
// nearest crossing on each side that has a known end point).
bool IsExtremumAlong(const Mesh& mesh, const Topology& topo, const CurvatureField& f, const std::vector<Compared>& c,
                     int32_t v, const Vec3& dir, int which, double sign) {
  const int32_t* ring = topo.ring.data() + topo.ring_offsets[v];
  const int32_t n = topo.valence(v);
  const Vec3 p = mesh.positions[v];
  const Vec3 side = Cross(f.normal[v], dir);  // normal of the cutting plane
  // Nearest crossing ahead of P (along > 0) and behind it (along < 0).
  double ahead_along = HUGE_VAL, behind_along = -HUGE_VAL, ahead_value = 0.0, behind_value = 0.0;
  Vec3 e0 = mesh.positions[ring[n - 1]] - p;
  double s0 = Dot(side, e0);
  int32_t q0 = ring[n - 1];
  for (int32_t k = 0; k < n; ++k) {
    const int32_t q1 = ring[k];
    const Vec3 e1 = mesh.positions[q1] - p;
    const double s1 = Dot(side, e1);
    if ((s0 >= 0.0) != (s1 >= 0.0)) {
      const double t = s0 / (s0 - s1);  // the signs differ, so the denominator is not zero
      const double along = Dot(dir, e0) + t * Dot(dir, e1 - e0);
      // From the end points with a value only: one poor neighbour does not hide a crest. An
      // edge with neither gives no crossing.
      const bool valid0 = c[q0].known(), valid1 = c[q1].known();
      const double value0 = c[q0].k[which], value1 = c[q1].k[which];
      const double value = valid0 && valid1 ? value0 + t * (value1 - value0) : valid0 ? value0 : value1;
      if (!valid0 && !valid1) {
        // no value on this edge
      } else if (along > 0.0 && along < ahead_along) {
        ahead_along = along;
        ahead_value = value;
      } else if (along < 0.0 && along > behind_along) {
        behind_along = along;
        behind_value = value;
      }
    }
    e0 = e1;
    s0 = s1;
    q0 = q1;
  }
  if (ahead_along == HUGE_VAL || behind_along == -HUGE_VAL) return false;
  const double here = sign * c[v].k[which];
  return here > sign * ahead_value && here > sign * behind_value;
}

FeatureLabel Classify(const Mesh& mesh, const Topology& topo, const CurvatureField& f, const std::vector<Compared>& c,
                      int32_t v, double threshold) {
  if (!f.valid[v]) return FeatureLabel::kNone;
  const double kmax = c[v].k[0], kmin = c[v].k[1];
  const bool ridge = kmax > 0.0 && kmax > threshold && IsExtremumAlong(mesh, topo, f, c, v, f.dir_max[v], 0, 1.0);
  const bool ravine = kmin < 0.0 && -kmin > threshold && IsExtremumAlong(mesh, topo, f, c, v, f.dir_min[v], 1, -1.0);
  if (ridge && ravine) return kmax >= -kmin ? FeatureLabel::kRidge : FeatureLabel::kRavine;
  if (ridge) return FeatureLabel::kRidge;
  return ravine ? FeatureLabel::kRavine : FeatureLabel::kNone;
}

}  // namespace

Features DetectFeatures(const Mesh& mesh, const Topology& topology, const FeatureOptions& options,
                        const StopToken& stop) {
  Features out;
  out.curvature = EstimateCurvature(mesh, topology, stop);
  const int32_t n = topology.num_vertices();
  out.labels.assign(n, static_cast<uint8_t>(FeatureLabel::kNone));
  const CurvatureField& f = out.curvature;
  const std::vector<Compared> compared = RingMeans(topology, f);
  out.threshold = std::max(0.0, options.min_abs_curvature);
  if (options.relative_threshold > 0.0) {
    std::vector<double> scale;
    for (int32_t v = 0; v < n; ++v) {
      const double k = std::max(std::abs(compared[v].k[0]), std::abs(compared[v].k[1]));
      if (f.valid[v] && std::isfinite(k)) scale.push_back(k);
    }
    if (!scale.empty()) {
      const auto at = scale.begin() + static_cast<std::ptrdiff_t>(0.9 * static_cast<double>(scale.size() - 1));
      std::nth_element(scale.begin(), at, scale.end());
      out.threshold = std::max(out.threshold, options.relative_threshold * *at);
    }
  }
  // Each vertex writes only its own label: the result does not depend on the thread count.
  std::atomic<bool> stopped{false};
#pragma omp parallel for schedule(static) if (n >= kParallelMin)
  for (int32_t v = 0; v < n; ++v) {
    if (v % kStopPollInterval == 0 && stop.Fired()) stopped.store(true, std::memory_order_relaxed);
    if (stopped.load(std::memory_order_relaxed)) continue;
    out.labels[v] = static_cast<uint8_t>(Classify(mesh, topology, f, compared, v, out.threshold));
  }
  for (uint8_t valid : f.valid) out.classified += valid != 0;
  for (uint8_t l : out.labels) {
    out.ridges += l == static_cast<uint8_t>(FeatureLabel::kRidge);
    out.ravines += l == static_cast<uint8_t>(FeatureLabel::kRavine);
  }
  return out;
}

std::vector<GenericAttribute> FeatureAttributes(const Features& features) {
  std::vector<float> kmax(features.curvature.kmax.begin(), features.curvature.kmax.end());
  std::vector<float> kmin(features.curvature.kmin.begin(), features.curvature.kmin.end());
  std::vector<GenericAttribute> out;
  out.push_back({kFeatureLabelAttribute, features.labels});
  out.push_back({kKmaxAttribute, std::move(kmax)});
  out.push_back({kKminAttribute, std::move(kmin)});
  return out;
}

std::vector<Rgb> FeatureColors(const std::vector<uint8_t>& labels) {
  std::vector<Rgb> colors(labels.size(), Rgb{200, 200, 200});
  for (size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] == static_cast<uint8_t>(FeatureLabel::kRidge)) colors[i] = Rgb{0, 0, 0};
    if (labels[i] == static_cast<uint8_t>(FeatureLabel::kRavine)) colors[i] = Rgb{255, 255, 255};
  }
  return colors;
}

}  // namespace meshsmooth
