#include "core/measure/noise.h"

#include <omp.h>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <vector>

#include "core/measure/normal_turn.h"
#include "core/normals.h"

namespace meshsmooth {
namespace {

constexpr int kTerms = 10;

// A fit whose design is this ill-conditioned (its pivots relative to the largest) says
// nothing: a ring that spans a line, or points that coincide.
constexpr double kMinRelativePivot = 1e-9;
// 1 / Phi^-1(3/4): the median of |x| for x ~ N(0, sigma^2) is sigma / 1.4826.
constexpr double kMadToSigma = 1.4826;
// The deviation is the root mean square of the residuals within this many robust scales;
// E[x^2 1{|x| <= 3}] for x ~ N(0, 1) is 1 - 2 Phi(-3) - 6 phi(3) = 0.97071.
constexpr double kTrimSigmas = 3.0;
constexpr double kTrimmedSecondMoment = 0.97071;
// Marks a vertex whose fit was tried but not well posed.
constexpr double kUnusable = -1.0;
// A second ring is gathered from at most this many ring entries (regular meshes: ~40)...
constexpr size_t kMaxGather = 1024;
// ... and a third ring, for the wide fits, from this many times as many.
constexpr size_t kWideGather = 4;

// The fit at vertex v (header comment): its residual r (v's height above the fitted surface, in
// h), the fit's own variance g at v, and the frame's normal n.
struct Fit {
  double r = 0.0, g = 0.0;
  Vec3 n;
};

// Per-thread buffers of FitAt: the second ring, and per vertex the stamp of the last fit that
// gathered it (duplicates are dropped as they come, without sorting).
struct FitScratch {
  std::vector<int32_t> ring2;
  std::vector<uint32_t> seen;
  uint32_t stamp = 0;
};

// An interior vertex's fan (v and consecutive ring entries), from one walk around it: the sum
// of its faces' cross products (RingNormal's, the same bits), and whether v lies on a crease
// between smooth parts: two or more pairs of consecutive faces meet at a sharp edge (their
// normals more than crease_sharp_deg apart) and every other pair meets flat (less than
// crease_flat_deg, NoiseParams). A fan of fewer than three faces, or with a face of no area, is not on a
// crease.
struct Fan {
  Vec3 normal;
  bool on_crease = false;
};

// The squared cosines of NoiseParams' crease angles: compared squared, without a root or a
// division, a . b < c |a| |b| with c > 0 holds when a . b < 0 or (a . b)^2 < c^2 |a|^2 |b|^2, and
// a . b > c |a| |b| when a . b > 0 and (a . b)^2 > c^2 |a|^2 |b|^2.
struct CreaseCosines {
  explicit CreaseCosines(const NoiseParams& p)
      : sharp2(Squared(std::cos(p.crease_sharp_deg * std::numbers::pi / 180.0))),
        flat2(Squared(std::cos(p.crease_flat_deg * std::numbers::pi / 180.0))) {}
  static double Squared(double c) { return c * c; }
  double sharp2, flat2;
};

Fan FanAt(const Vec3* pos, const Topology& topo, int32_t v, const CreaseCosines& cosines) {
  const int32_t begin = topo.ring_offsets[v], end = topo.ring_offsets[v + 1];
  Fan fan;
  if (end == begin) return fan;
  const Vec3& p = pos[v];
  auto face = [&](int32_t k) {  // the cross product of the fan's face k
    return Cross(pos[topo.ring[k]] - p, pos[topo.ring[k + 1 < end ? k + 1 : begin]] - p);
  };
  // RingNormal's order: the face that closes the fan first, then the others from the first.
  const Vec3 last = face(end - 1);
  fan.normal += last;
  Vec3 before = last;
  double before2 = SquaredNorm(last);
  bool flat_or_sharp = end - begin >= 3;
  int sharp = 0;
  for (int32_t k = begin; k < end; ++k) {
    const Vec3 cur = k + 1 < end ? face(k) : last;
    if (k + 1 < end) fan.normal += cur;
    if (!flat_or_sharp) continue;
    const double cur2 = SquaredNorm(cur);
    const double dot = Dot(before, cur), lengths2 = before2 * cur2;
    if (!(before2 > 0.0) || !(cur2 > 0.0)) {
      flat_or_sharp = false;
    } else if (dot < 0.0 || dot * dot < cosines.sharp2 * lengths2) {
      ++sharp;
    } else if (!(dot * dot > cosines.flat2 * lengths2)) {
      flat_or_sharp = false;
    }
    before = cur, before2 = cur2;
  }
  fan.on_crease = flat_or_sharp && sharp >= 2;
  return fan;
}

// The fit at vertex v, whose ring normal (RingNormal) is `normal`, or none when it is not well
// posed (or v's second ring is too large to gather: a fan's rim around a centre of huge
// valence, skipped in bounded time).
std::optional<Fit> FitAt(const Mesh& mesh, const Topology& topo, int32_t v, const Vec3& normal, double inv_h,
                         FitScratch& s, int32_t min_points, bool wide = false) {
  const Vec3* pos = mesh.positions.data();
  const double len = Norm(normal);
  if (!(len > 0.0) || !std::isfinite(len)) return std::nullopt;
  const Vec3 n = normal * (1.0 / len);
  // Any unit vector across n, then the third axis.
  const Vec3 helper = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 t1 = Normalized(Cross(n, helper));
  const Vec3 t2 = Cross(n, t1);

  // The first and second rings, v left out, each vertex once, in the order they come; a gather
  // of more than kMaxGather ring entries gives up.
  const auto n_vertices = static_cast<size_t>(topo.num_vertices());
  if (s.seen.size() != n_vertices || ++s.stamp == 0) {
    s.seen.assign(n_vertices, 0);
    s.stamp = 1;
  }
  const uint32_t stamp = s.stamp;
  uint32_t* const seen = s.seen.data();
  std::vector<int32_t>& ring2 = s.ring2;
  ring2.clear();
  seen[v] = stamp;
  size_t gathered = 0;
  for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) {
    const int32_t u = topo.ring[k];
    const int32_t first = topo.ring_offsets[u], last = topo.ring_offsets[u + 1];
    gathered += 1 + static_cast<size_t>(last - first);
    if (gathered > kMaxGather) return std::nullopt;
    if (seen[u] != stamp) seen[u] = stamp, ring2.push_back(u);
    for (int32_t j = first; j < last; ++j) {
      const int32_t w = topo.ring[j];
      if (seen[w] != stamp) seen[w] = stamp, ring2.push_back(w);
    }
  }
  if (wide) {  // and the third ring: the neighbours of the second
    const size_t inner = ring2.size();
    for (size_t i = 0; i < inner; ++i) {
      const int32_t u = ring2[i];
      const int32_t first = topo.ring_offsets[u], last = topo.ring_offsets[u + 1];
      gathered += static_cast<size_t>(last - first);
      if (gathered > kWideGather * kMaxGather) return std::nullopt;
      for (int32_t j = first; j < last; ++j) {
        const int32_t w = topo.ring[j];
        if (seen[w] != stamp) seen[w] = stamp, ring2.push_back(w);
      }
    }
  }
  if (static_cast<int32_t>(ring2.size()) < min_points) return std::nullopt;

  // The ring in the tangent plane, whitened: mapped linearly so that its second moment about v
  // is the identity (by the Cholesky factor of that moment). A cubic in (x, y) is a cubic in any
  // linear map of them, so the prediction at v and its variance do not change, but the normal
  // equations of a needle-shaped ring (CAD tessellations) stay well conditioned. Heights in
  // units of h.
  const Vec3 p = pos[v];
  double mxx = 0.0, mxy = 0.0, myy = 0.0;
  for (int32_t u : ring2) {
    const Vec3 q = (pos[u] - p) * inv_h;
    const double x = Dot(q, t1), y = Dot(q, t2);
    mxx += x * x, mxy += x * y, myy += y * y;
  }
  // The moment's eigenvalues: the ring spans a line (or its points coincide) when the smaller
  // is below kMinRelativePivot times the larger.
  const double half_trace = 0.5 * (mxx + myy), det = mxx * myy - mxy * mxy;
  const double larger = half_trace + std::sqrt(0.25 * (mxx - myy) * (mxx - myy) + mxy * mxy);
  if (!(larger > 0.0) || !(det > kMinRelativePivot * larger * larger)) return std::nullopt;
  const double count = static_cast<double>(ring2.size());
  const double l11 = std::sqrt(mxx / count), l21 = mxy / count / l11, l22 = std::sqrt(myy / count - l21 * l21);
  if (!(l22 > 0.0)) return std::nullopt;

  // The normal equations of the least-squares cubic, its terms ordered x^3, x^2 y, x y^2, y^3,
  // x^2, x y, y^2, x, y, 1 (the constant last), lower triangle only.
  double ata[kTerms][kTerms] = {}, atz[kTerms] = {};
  for (int32_t u : ring2) {
    const Vec3 q = (pos[u] - p) * inv_h;
    const double x = Dot(q, t1) / l11;
    const double y = (Dot(q, t2) - l21 * x) / l22;
    const double z = Dot(q, n);
    const double row[kTerms] = {x * x * x, x * x * y, x * y * y, y * y * y, x * x, x * y, y * y, x, y, 1.0};
#pragma GCC unroll 10
    for (int i = 0; i < kTerms; ++i) {
#pragma GCC unroll 10
      for (int j = 0; j <= i; ++j) ata[i][j] += row[i] * row[j];
      atz[i] += row[i] * z;
    }
  }
  // Cholesky, A^T A = L L^T, in place; with the constant last, the fit's constant is
  // (L^-1 A^T z)_last / L_last,last and its variance [(A^T A)^-1]_last,last = 1 / L_last,last^2,
  // so one forward substitution gives both. A pivot below kMinRelativePivot times the largest
  // diagonal entry: not well posed.
  double largest = 0.0;
  for (int i = 0; i < kTerms; ++i) largest = std::max(largest, ata[i][i]);
  double w[kTerms];
  for (int j = 0; j < kTerms; ++j) {
    double pivot = ata[j][j];
    for (int k = 0; k < j; ++k) pivot -= ata[j][k] * ata[j][k];
    if (!(pivot > kMinRelativePivot * largest)) return std::nullopt;
    const double ljj = std::sqrt(pivot);
    ata[j][j] = ljj;
    for (int i = j + 1; i < kTerms; ++i) {
      double sum = ata[i][j];
      for (int k = 0; k < j; ++k) sum -= ata[i][k] * ata[j][k];
      ata[i][j] = sum / ljj;
    }
    double rhs = atz[j];
    for (int k = 0; k < j; ++k) rhs -= ata[j][k] * w[k];
    w[j] = rhs / ljj;
  }
  const double last = ata[kTerms - 1][kTerms - 1];
  const double g = 1.0 / (last * last);
  const double r = -w[kTerms - 1] / last;
  if (!std::isfinite(r) || !(g >= 0.0)) return std::nullopt;
  return Fit{r, g, n};
}

// The normalised residual r / sqrt(1 + g) of vertex v, or NaN when its fit is not well posed.
double NormalisedResidual(const Mesh& mesh, const Topology& topo, int32_t v, const Vec3& normal, double inv_h,
                          FitScratch& scratch, int32_t min_points, bool wide = false) {
  const std::optional<Fit> fit = FitAt(mesh, topo, v, normal, inv_h, scratch, min_points, wide);
  return fit ? fit->r / std::sqrt(1.0 + fit->g) : std::numeric_limits<double>::quiet_NaN();
}

// Per-thread buffers of RingMedianHeight.
struct RingScratch {
  std::vector<int32_t> ids;
  std::vector<double> off, sorted, heights;
};

// The median of `values` (the upper one of an even count); reorders them.
double Median(std::vector<double>& values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// The unit normal of the least-squares plane (principal components) through pos[ids]; none when
// the points span less than a plane.
std::optional<Vec3> PlaneNormal(const Vec3* pos, const std::vector<int32_t>& ids) {
  if (ids.size() < 3) return std::nullopt;
  Vec3 centre;
  for (int32_t u : ids) centre += pos[u];
  centre *= 1.0 / static_cast<double>(ids.size());
  Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
  for (int32_t u : ids) {
    const Vec3 d = pos[u] - centre;
    const Eigen::Vector3d e(d.x, d.y, d.z);
    moment += e * e.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(moment);
  if (pca.info() != Eigen::Success || !(pca.eigenvalues()(1) > 0.0)) return std::nullopt;
  const Eigen::Vector3d least = pca.eigenvectors().col(0);  // eigenvalues ascending
  const Vec3 unit{least(0), least(1), least(2)};
  if (!IsFinite(unit)) return std::nullopt;
  return unit;
}

// The normal of the least-squares plane through pos[ids], fitted again without the points more
// than three times the median offset off it; `ids` keeps the points of the last fit.
std::optional<Vec3> TrimmedPlaneNormal(const Vec3* pos, std::vector<int32_t>& ids, RingScratch& s) {
  const std::optional<Vec3> unit = PlaneNormal(pos, ids);
  if (!unit) return std::nullopt;
  Vec3 centre;
  for (int32_t u : ids) centre += pos[u];
  centre *= 1.0 / static_cast<double>(ids.size());
  s.off.resize(ids.size());
  for (size_t i = 0; i < ids.size(); ++i) s.off[i] = std::abs(Dot(pos[ids[i]] - centre, *unit));
  s.sorted = s.off;
  const double keep = 3.0 * Median(s.sorted);
  size_t kept = 0;
  for (size_t i = 0; i < ids.size(); ++i) {
    if (s.off[i] <= keep) ids[kept++] = ids[i];
  }
  if (kept == ids.size() || kept < 3) return unit;
  ids.resize(kept);
  return PlaneNormal(pos, ids);
}

// The normal of the plane through pos[ids] that resists points thrown off it: least median of
// squares (Rousseeuw 1984) over lmeds_triples planes through three of the points (drawn with a
// generator seeded by v), then the least-squares plane of the points within
// lmeds_inlier_scales robust scales of it or lmeds_floor_h mean edges `h` (NoiseParams). A least-squares plane
// through a rim's dozen points, three of them thrown 2 h, leans by ~45 degrees; least median of
// squares ignores up to half. `ids` keeps the points of the last fit.
std::optional<Vec3> RobustPlaneNormal(const Vec3* pos, std::vector<int32_t>& ids, int32_t v, double h, RingScratch& s,
                                      const NoiseParams& params) {
  const auto n = static_cast<int64_t>(ids.size());
  if (n < 3) return std::nullopt;
  if (n == 3) return PlaneNormal(pos, ids);
  uint64_t state = 0x9E3779B97F4A7C15ull ^ static_cast<uint64_t>(v);
  auto draw = [&]() {  // splitmix64
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return static_cast<int64_t>((z ^ (z >> 31)) % static_cast<uint64_t>(n));
  };
  double best = std::numeric_limits<double>::infinity();
  Vec3 best_point, best_normal;
  s.off.resize(ids.size());
  auto try_plane = [&](int64_t i, int64_t j, int64_t k) {
    const Vec3 a = pos[ids[i]];
    const Vec3 normal = Cross(pos[ids[j]] - a, pos[ids[k]] - a);
    const double length = Norm(normal);
    if (!(length > 0.0) || !std::isfinite(length)) return;
    const Vec3 unit = normal * (1.0 / length);
    for (int64_t m = 0; m < n; ++m) s.off[m] = std::abs(Dot(pos[ids[m]] - a, unit));
    const double median = Median(s.off);  // the offsets are not read again
    if (median < best) {
      best = median;
      best_point = a;
      best_normal = unit;
    }
  };
  for (int32_t t = 0; t < params.lmeds_triples; ++t) {
    const int64_t i = draw(), j = draw(), k = draw();
    if (i != j && j != k && i != k) try_plane(i, j, k);
  }
  if (!std::isfinite(best)) return PlaneNormal(pos, ids);
  const double cut = std::max(params.lmeds_inlier_scales * kMadToSigma * best, params.lmeds_floor_h * h);
  size_t kept = 0;
  for (int32_t u : ids) {
    if (std::abs(Dot(pos[u] - best_point, best_normal)) <= cut) ids[kept++] = u;
  }
  ids.resize(kept);
  const std::optional<Vec3> refined = PlaneNormal(pos, ids);
  return refined ? refined : std::optional<Vec3>(best_normal);
}

// The median height above v of its ring's inliers (the vertices not flagged in `skip`, when at
// least three are not; else all of them), along the normal of a plane through the inliers of its
// first and second rings, into `axis`: a dozen points or more, where the ring's own polygon leans
// by tens of degrees when some of it is thrown. The least-squares plane, trimmed; with
// `robust_h` > 0, the plane RobustPlaneNormal fits with that floor instead. None for a degenerate
// ring.
std::optional<double> RingMedianHeight(const Vec3* pos, const Topology& topo, int32_t v, const uint8_t* skip,
                                       double robust_h, RingScratch& s, Vec3* axis, const NoiseParams& params) {
  const int32_t first = topo.ring_offsets[v], last = topo.ring_offsets[v + 1];
  if (last - first < 3) return std::nullopt;
  int32_t inliers = 0;
  for (int32_t k = first; k < last; ++k) inliers += skip == nullptr || !skip[topo.ring[k]];
  const bool all = inliers < 3;
  auto inlier = [&](int32_t w) { return all || skip == nullptr || !skip[w]; };
  std::vector<int32_t>& ids = s.ids;
  ids.clear();
  for (int32_t k = first; k < last; ++k) {
    const int32_t w = topo.ring[k];
    if (!inlier(w)) continue;
    ids.push_back(w);
    for (int32_t j = topo.ring_offsets[w]; j < topo.ring_offsets[w + 1] && ids.size() < kMaxGather; ++j) {
      const int32_t u = topo.ring[j];
      if (u != v && inlier(u)) ids.push_back(u);
    }
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  const std::optional<Vec3> normal =
      robust_h > 0.0 ? RobustPlaneNormal(pos, ids, v, robust_h, s, params) : TrimmedPlaneNormal(pos, ids, s);
  if (!normal) return std::nullopt;
  const Vec3 unit = *normal;
  s.heights.clear();
  for (int32_t k = first; k < last; ++k) {
    if (inlier(topo.ring[k])) s.heights.push_back(Dot(pos[topo.ring[k]] - pos[v], unit));
  }
  if (axis != nullptr) *axis = unit;
  return Median(s.heights);
}

}  // namespace

NoiseEstimate EstimateNoise(const Mesh& mesh, const Topology& topo, double h, int threads, const StopToken& stop,
                            const uint8_t* skip, const NoiseParams& params) {
  NoiseEstimate estimate;
  const int32_t n = topo.num_vertices();
  if (!(h > 0.0) || !std::isfinite(h) || n == 0) return estimate;
  if (threads <= 0) threads = omp_get_max_threads();
  const double inv_h = 1.0 / h;
  // At most about max_fits vertices are fitted: the median of n residuals has a relative standard
  // error of ~1.17 / sqrt(n), 0.8% at 20,000.
  const int32_t stride = std::max<int32_t>(1, (n + params.max_fits - 1) / params.max_fits);
  // One entry per vertex tried (every stride-th one): bounded by ~max_fits, whatever the mesh.
  std::vector<double> residual((n + stride - 1) / stride, std::numeric_limits<double>::quiet_NaN());
  bool stopped = false;
  const auto tried = static_cast<int32_t>(residual.size());
  // The wide fits' residuals, on every wide_stride-th vertex tried (NaN elsewhere).
  const int32_t wide_stride = std::max<int32_t>(1, (tried + params.max_wide_fits - 1) / params.max_wide_fits);
  std::vector<double> wide(residual.size(), std::numeric_limits<double>::quiet_NaN());
  int64_t creases = 0;  // tried vertices on a crease (FanAt; an integer sum: any order)
  const CreaseCosines cosines(params);
#pragma omp parallel num_threads(threads) if (threads > 1 && tried >= kMinParallelFits) reduction(+ : creases)
  {
    FitScratch fit_scratch;
#pragma omp for schedule(static, 128)
    for (int32_t i = 0; i < tried; ++i) {
      if (i % 256 == 0 && stop.Fired()) {
#pragma omp atomic write
        stopped = true;
      }
      bool give_up;
#pragma omp atomic read
      give_up = stopped;
      const int32_t v = i * stride;
      if (give_up || topo.kind[v] != VertexKind::kInterior || (skip != nullptr && skip[v] != 0)) continue;
      const Fan fan = FanAt(mesh.positions.data(), topo, v, cosines);
      creases += fan.on_crease;
      residual[i] = std::abs(NormalisedResidual(mesh, topo, v, fan.normal, inv_h, fit_scratch, params.min_fit_points));
      if (std::isnan(residual[i])) residual[i] = kUnusable;
      if (i % wide_stride == 0 && residual[i] >= 0.0) {
        wide[i] = std::abs(
            NormalisedResidual(mesh, topo, v, fan.normal, inv_h, fit_scratch, params.min_fit_points, /*wide=*/true));
      }
    }
  }
  if (stopped) return estimate;
  // The vertices with both fits well posed.
  std::vector<double> narrow_pair, wide_pair;
  for (size_t i = 0; i < wide.size(); ++i) {
    if (!(wide[i] >= 0.0)) continue;
    narrow_pair.push_back(residual[i]);
    wide_pair.push_back(wide[i]);
  }
  // NaN: not tried; kUnusable: tried, the fit not well posed. The median of the rest.
  for (double r : residual) estimate.vertices_tried += !std::isnan(r);
  if (estimate.vertices_tried > 0) {
    estimate.crease_share = static_cast<double>(creases) / static_cast<double>(estimate.vertices_tried);
  }
  residual.erase(std::remove_if(residual.begin(), residual.end(), [](double r) { return !(r >= 0.0); }),
                 residual.end());
  estimate.vertices_used = static_cast<int64_t>(residual.size());
  if (estimate.vertices_used < params.min_well_posed ||
      estimate.vertices_used * params.well_posed_share < estimate.vertices_tried ||
      estimate.crease_share > params.max_crease_share) {
    return estimate;
  }
  const size_t mid = residual.size() / 2;
  std::nth_element(residual.begin(), residual.begin() + static_cast<std::ptrdiff_t>(mid), residual.end());
  estimate.reliable = true;
  estimate.sigma_h = kMadToSigma * residual[mid];
  estimate.sigma = estimate.sigma_h * h;
  // The deviation itself, from the residuals within kTrimSigmas of the robust scale (creases and
  // corners lie further out): their mean square over every residual, corrected for the
  // Gaussian's share of it inside the cut.
  const double cut = kTrimSigmas * estimate.sigma_h;
  double sum = 0.0;
  for (double r : residual) sum += r <= cut ? r * r : 0.0;
  estimate.deviation_h = std::sqrt(sum / static_cast<double>(residual.size()) / kTrimmedSecondMoment);
  estimate.detail_free_h = estimate.sigma_h;
  if (static_cast<int64_t>(narrow_pair.size()) >= params.min_well_posed) {
    const double narrow = kMadToSigma * Median(narrow_pair), far = kMadToSigma * Median(wide_pair);
    const double k2 = params.detail_wide_ratio * params.detail_wide_ratio,
                 c2 = params.noise_wide_ratio * params.noise_wide_ratio;
    estimate.detail_free_h = std::sqrt(std::max(0.0, (k2 * narrow * narrow - far * far) / (k2 - c2)));
  }
  estimate.normal_turn = PredictedNormalNoise(mesh, topo, estimate.sigma);
  const double outlier = OutlierThresholdH(estimate, params);
  int64_t outliers = 0;
  for (double r : residual) outliers += r > outlier;
  estimate.outlier_share = static_cast<double>(outliers) / static_cast<double>(residual.size());
  return estimate;
}

struct LocalFit::Buffers {
  FitScratch fit;
  RingScratch ring;
};

LocalFit::LocalFit(const NoiseParams& params) : params_(params), buffers_(std::make_unique<Buffers>()) {}
LocalFit::~LocalFit() = default;

std::optional<double> LocalFit::ResidualH(const Mesh& mesh, const Topology& topo, int32_t v, double h) {
  const std::optional<Fit> fit =
      FitAt(mesh, topo, v, RingNormal(topo, mesh.positions.data(), v), 1.0 / h, buffers_->fit, params_.min_fit_points);
  if (!fit) return std::nullopt;
  return std::abs(fit->r) / std::sqrt(1.0 + fit->g);
}

std::optional<double> LocalFit::RingHeight(const Vec3* pos, const Topology& topo, int32_t v, const uint8_t* skip,
                                           Vec3* axis) {
  return RingMedianHeight(pos, topo, v, skip, 0.0, buffers_->ring, axis, params_);
}

std::optional<double> LocalFit::RobustRingHeight(const Vec3* pos, const Topology& topo, int32_t v, double h,
                                                 const uint8_t* skip, Vec3* axis) {
  return RingMedianHeight(pos, topo, v, skip, h, buffers_->ring, axis, params_);
}

}  // namespace meshsmooth
