#include "core/measure/noise.h"

#include <omp.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/normals.h"

namespace meshsmooth {
namespace {

constexpr int kTerms = 10;
using Mat = Eigen::Matrix<double, kTerms, kTerms>;
using Col = Eigen::Matrix<double, kTerms, 1>;

// A fit needs more points than its 6 unknowns to say anything about the noise.
constexpr int kMinFitPoints = 14;
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
// At most about this many vertices are fitted (every k-th vertex of a larger mesh): the median
// of n residuals has a relative standard error of ~1.17 / sqrt(n), 0.8% at 20,000. Against
// 50,000 fits, the deviation of the benchmark's noisy bunny, nefertiti and dragon moves by
// 0.1-1.0% and every default row of docs/quality.md on the meshes above 20,000 vertices stays
// within 1.005x; the estimate takes 20-27 ms instead of 39-62 ms on them (docs/decisions.md).
constexpr int32_t kMaxFits = 20000;
// Fewer fits than this run on one thread: a fit costs ~2 us, so below it waking a second
// thread is not worth it.
constexpr int32_t kMinParallelFits = 2000;
// The least number of well-posed fits, absolute and as a share of the vertices tried, for the
// median to be an estimate.
constexpr int64_t kMinWellPosed = 25;
// A second ring is gathered from at most this many ring entries (regular meshes: ~40).
constexpr size_t kMaxGather = 1024;
constexpr int64_t kMinWellPosedPerTried = 4;  // one in four

// The normalised residual r / sqrt(1 + g) of vertex v (header comment), or NaN when its fit is
// not well posed (or v's second ring too large to gather: a fan's rim around a centre of huge
// valence, skipped in bounded time).
double NormalisedResidual(const Mesh& mesh, const Topology& topo, int32_t v, double inv_h,
                          std::vector<int32_t>& ring2) {
  const Vec3* pos = mesh.positions.data();
  const Vec3 normal = RingNormal(topo, pos, v);
  const double len = Norm(normal);
  if (!(len > 0.0) || !std::isfinite(len)) return std::numeric_limits<double>::quiet_NaN();
  const Vec3 n = normal * (1.0 / len);
  // Any unit vector across n, then the third axis.
  const Vec3 helper = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 t1 = Normalized(Cross(n, helper));
  const Vec3 t2 = Cross(n, t1);

  // The first and second rings, v left out; duplicates removed after a bounded gather.
  ring2.clear();
  for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) {
    const int32_t u = topo.ring[k];
    const int32_t first = topo.ring_offsets[u], last = topo.ring_offsets[u + 1];
    if (ring2.size() + 1 + static_cast<size_t>(last - first) > kMaxGather) {
      return std::numeric_limits<double>::quiet_NaN();
    }
    ring2.push_back(u);
    ring2.insert(ring2.end(), topo.ring.begin() + first, topo.ring.begin() + last);
  }
  std::sort(ring2.begin(), ring2.end());
  ring2.erase(std::unique(ring2.begin(), ring2.end()), ring2.end());
  ring2.erase(std::remove(ring2.begin(), ring2.end(), v), ring2.end());
  if (static_cast<int>(ring2.size()) < kMinFitPoints) return std::numeric_limits<double>::quiet_NaN();

  // The ring in the tangent plane, whitened: along the principal axes of its second moment
  // about v, each scaled to unit spread. A cubic in (x, y) is a cubic in any linear map of them,
  // so the prediction at v and its variance do not change, but the normal equations of a
  // needle-shaped ring (CAD tessellations) stay well conditioned. Heights in units of h.
  const Vec3 p = pos[v];
  Eigen::Matrix2d moment = Eigen::Matrix2d::Zero();
  for (int32_t u : ring2) {
    const Vec3 q = (pos[u] - p) * inv_h;
    const Eigen::Vector2d xy(Dot(q, t1), Dot(q, t2));
    moment += xy * xy.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> axes(moment);
  const Eigen::Vector2d spread = axes.eigenvalues();
  if (axes.info() != Eigen::Success || !(spread(0) > kMinRelativePivot * spread(1))) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  Eigen::Matrix2d whiten = axes.eigenvectors().transpose();
  whiten.row(0) /= std::sqrt(spread(0) / static_cast<double>(ring2.size()));
  whiten.row(1) /= std::sqrt(spread(1) / static_cast<double>(ring2.size()));

  Mat ata = Mat::Zero();
  Col atz = Col::Zero();
  for (int32_t u : ring2) {
    const Vec3 q = (pos[u] - p) * inv_h;
    const Eigen::Vector2d xy = whiten * Eigen::Vector2d(Dot(q, t1), Dot(q, t2));
    const double x = xy(0), y = xy(1), z = Dot(q, n);
    Col row;
    row << 1.0, x, y, x * x, x * y, y * y, x * x * x, x * x * y, x * y * y, y * y * y;
    ata.selfadjointView<Eigen::Lower>().rankUpdate(row);
    atz += row * z;
  }
  ata = ata.selfadjointView<Eigen::Lower>();
  const Eigen::LDLT<Mat> ldlt(ata);
  if (ldlt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  const auto d = ldlt.vectorD();
  const double largest = d.cwiseAbs().maxCoeff();
  if (!(largest > 0.0) || !(d.minCoeff() > kMinRelativePivot * largest))
    return std::numeric_limits<double>::quiet_NaN();
  const Col coef = ldlt.solve(atz);
  Col unit_f = Col::Zero();
  unit_f(0) = 1.0;
  const double g = ldlt.solve(unit_f)(0);
  const double r = -coef(0);
  if (!std::isfinite(r) || !(g >= 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return r / std::sqrt(1.0 + g);
}

}  // namespace

NoiseEstimate EstimateNoise(const Mesh& mesh, const Topology& topo, double h, int threads, const StopToken& stop) {
  NoiseEstimate estimate;
  const int32_t n = topo.num_vertices();
  if (!(h > 0.0) || !std::isfinite(h) || n == 0) return estimate;
  if (threads <= 0) threads = omp_get_max_threads();
  const double inv_h = 1.0 / h;
  const int32_t stride = std::max<int32_t>(1, (n + kMaxFits - 1) / kMaxFits);
  // One entry per vertex tried (every stride-th one): bounded by ~kMaxFits, whatever the mesh.
  std::vector<double> residual((n + stride - 1) / stride, std::numeric_limits<double>::quiet_NaN());
  bool stopped = false;
  const auto tried = static_cast<int32_t>(residual.size());
#pragma omp parallel num_threads(threads) if (threads > 1 && tried >= kMinParallelFits)
  {
    std::vector<int32_t> ring2;
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
      if (give_up || topo.kind[v] != VertexKind::kInterior) continue;
      residual[i] = std::abs(NormalisedResidual(mesh, topo, v, inv_h, ring2));
      if (std::isnan(residual[i])) residual[i] = kUnusable;
    }
  }
  if (stopped) return estimate;
  // NaN: not tried; kUnusable: tried, the fit not well posed. The median of the rest.
  for (double r : residual) estimate.vertices_tried += !std::isnan(r);
  residual.erase(std::remove_if(residual.begin(), residual.end(), [](double r) { return !(r >= 0.0); }),
                 residual.end());
  estimate.vertices_used = static_cast<int64_t>(residual.size());
  if (estimate.vertices_used < kMinWellPosed ||
      estimate.vertices_used * kMinWellPosedPerTried < estimate.vertices_tried) {
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
  return estimate;
}

}  // namespace meshsmooth
