// How noisy is a mesh? A robust estimate of the standard deviation of its vertices' offsets
// from the surface they sample, along the surface normal: what automatic stopping
// (FlowParams::iterations == 0, docs/quality-method.md) compares the flow's displacement with.
//
// For each interior vertex v, a cubic height field z(x, y) (ten terms, constant f) is fitted by
// least squares to v's first and second rings (v left out), in a frame whose z axis is v's
// area-weighted normal; v's residual is r = -f (v sits at the origin). With independent noise
// of deviation sigma along the normals, r has variance sigma^2 (1 + g), where g = [(A^T A)^-1]_ff
// is the fit's own variance at the origin (A: the fit's design matrix), so r / sqrt(1 + g) has
// deviation sigma. The estimate is 1.4826 x the median of |r| / sqrt(1 + g): the median
// ignores the minority of vertices on creases and corners, where a cubic cannot follow the
// surface. On a smooth, clean mesh the residuals are the fit's fourth-order terms, a small
// fraction of h; docs/quality.md gives the estimates of the benchmark's clean and noisy meshes.
// A mesh of more than 20,000 vertices is sampled: every k-th vertex is fitted.
//
// A mesh whose vertices lie almost all on creases has no estimate: when more than
// NoiseParams::max_crease_share of the vertices tried sit on a crease between smooth parts (FanAt in
// noise.cc: a fan of flat runs of faces meeting at sharp edges), the estimate is not reliable.
// Such a mesh (a CAD exporter's strips of slivers from one feature line to the next, fans of
// needles on flat caps) samples its surface along its creases only: every fit spans a crease,
// and the median of the residuals measures the creases, not noise (a clean stepped shaft of
// slivers read 0.38 h). The clean shaft has 99.6% of its vertices on creases; noise of 0.1-0.7 h
// along the normals leaves 30-52% that look so, a smooth tube of slivers with noise 44-55%; the
// other inputs of the quality benchmark counted, clean and noisy, at most 14%.
//
// Fine detail one or two edges wide (a scan decimated to a few thousand vertices) is not
// followed by a cubic either, and reads as noise. A second, wide fit over the first to third
// rings on a subsample tells them apart: its residual's robust scale s3 is about
// NoiseParams::noise_wide_ratio times the narrow one's, s2, under pure noise, and about NoiseParams::detail_wide_ratio
// times it for detail (the wider fit misses more of it). Taking s2^2 = sigma^2 + d^2 and
// s3^2 = c^2 sigma^2 + k^2 d^2, the detail-free estimate is
// sigma^2 = (k^2 s2^2 - s3^2) / (k^2 - c^2) (NoiseEstimate::detail_free_h; zero when negative).
// The clean decimated dragon reads 0.074 h of noise and 0.00 h detail-free; the same with 0.1
// and 0.2 h of noise 0.133 and 0.223 h, and 0.100 and 0.197 h detail-free (numpy).
//
// The same fits find outliers, vertices thrown far off the surface (a scanner's impulsive
// noise): their share tells that kind of noise (NoiseEstimate::outlier_share); the default job
// moves them back (RemoveOutliers, core/job/repair.h; docs/quality-method.md, "Outliers").
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "core/mesh.h"
#include "core/topology.h"
#include "core/util/stop_token.h"

namespace meshsmooth {

// The estimator's tuned numbers, one line each (the default job's copy is JobPolicy::noise,
// core/job/policy.h; docs/decisions.md has the figures that chose them). What noise.cc keeps as
// constants is mathematics (a Gaussian's quantiles and moments) or a bound on work.
struct NoiseParams {
  // Fits.
  int32_t max_fits = 20000;      // at most about this many vertices fitted (every k-th of a larger mesh)
  int32_t min_fit_points = 14;   // a fit needs this many second-ring points (its unknowns: 6)
  int32_t min_well_posed = 25;   // fewer well-posed fits: no estimate...
  int32_t well_posed_share = 4;  // ... nor with fewer than one in this many of those tried
  // Creases (FanAt in noise.cc; see above).
  double crease_sharp_deg = 45.0;  // two faces of a fan this far apart meet at a sharp edge...
  double crease_flat_deg = 20.0;   // ... and this close, flat
  double max_crease_share = 0.75;  // more of the vertices tried on a crease: no estimate
  // Outliers (NoiseEstimate::outlier_share, OutlierThresholdH).
  double outlier_scales = 5.0;   // a residual above this many robust scales...
  double outlier_floor_h = 0.5;  // ... and this many h is an outlier
  // The robust plane of LocalFit::RobustRingHeight (least median of squares).
  int32_t lmeds_triples = 50;        // planes through three points tried
  double lmeds_inlier_scales = 2.5;  // refitted to the points within this many robust scales...
  double lmeds_floor_h = 1.0;        // ... or this many h of the best plane
  // The detail-free estimate (the wide fits; see above).
  int32_t max_wide_fits = 1000;    // wide fits on at most about this many vertices
  double noise_wide_ratio = 0.94;  // a wide fit's robust scale over a narrow one's under noise...
  double detail_wide_ratio = 2.0;  // ... and under a clean mesh's fine detail
};

struct NoiseEstimate {
  double sigma = 0.0;    // in the mesh's units
  double sigma_h = 0.0;  // relative to the mean edge length h
  // The root mean square of the offsets, from the residuals within three robust scales of
  // zero: sigma_h for Gaussian noise, larger for noise whose distribution is more peaked (noise
  // in random directions, whose normal part is a Gaussian times a uniform cosine), where the
  // median reads low. What an estimate of a squared error needs (core/job/rules.h).
  double deviation_h = 0.0;
  int64_t vertices_used = 0;   // interior vertices with a well-posed fit
  int64_t vertices_tried = 0;  // interior vertices fitted (every k-th one of a large mesh)
  // The share of the well-posed fits whose normalised residual exceeds outlier_scales robust
  // scales and outlier_floor_h (NoiseParams): a few percent on clean CAD parts (creases a cubic cannot follow)
  // and under Gaussian noise, about the thrown share under impulsive noise (a scanner's outliers).
  double outlier_share = 0.0;
  // The share of the vertices tried that lie on a crease between smooth parts (see above).
  double crease_share = 0.0;
  // The noise with the fits' misfit of fine detail taken out, in h (see above): sigma_h when
  // too few vertices have both fits.
  double detail_free_h = 0.0;
  // How far offsets of deviation sigma, independent from vertex to vertex, turn this mesh's faces:
  // their mean angle in radians (PredictedNormalNoise, core/measure/normal_turn.h). Small offsets
  // turn thin triangles far: a fused scan's noise of 0.03-0.05 h turns its faces by 8-12 degrees.
  double normal_turn = 0.0;
  // False when too few fits were well posed for the median to mean anything (fewer than 25,
  // or fewer than a quarter of those tried: e.g. a fan whose rim vertices all see one circle),
  // or when more than max_crease_share of the vertices tried lie on a crease; sigma is then 0.
  bool reliable = false;
};

// The estimate for `mesh`; zero and not reliable when too few vertices have a well-posed fit
// (fewer than 14 second-ring neighbours, or a ring too degenerate for a cubic). `threads`: 0 = all hardware threads.
// Deterministic for any thread count. Returns early (an estimate of zero) once `stop` fires.
// Vertices where `skip` (per vertex; null: none) is non-zero are not fitted (the default job's
// vertices of strength 0, which no run moves); they still serve in their neighbours' fits.
NoiseEstimate EstimateNoise(const Mesh& mesh, const Topology& topo, double h, int threads = 0,
                            const StopToken& stop = {}, const uint8_t* skip = nullptr, const NoiseParams& params = {});

// The outlier threshold of `estimate`, in h (NoiseParams::outlier_scales, outlier_floor_h).
inline double OutlierThresholdH(const NoiseEstimate& estimate, const NoiseParams& params = {}) {
  return std::max(params.outlier_scales * estimate.sigma_h, params.outlier_floor_h);
}

// Fewer fits than this run on one thread: a fit costs ~1 us, so below it waking a second thread
// is not worth it.
inline constexpr int32_t kMinParallelFits = 2000;

// The estimate's measures one vertex at a time, for a caller that finds and moves outliers
// (core/job/repair.h). Holds buffers: one per thread.
class LocalFit {
 public:
  explicit LocalFit(const NoiseParams& params = {});
  ~LocalFit();
  LocalFit(const LocalFit&) = delete;
  LocalFit& operator=(const LocalFit&) = delete;

  // How far interior vertex v lies off the surface its first and second rings sample, in h: its
  // fit's normalised residual |r| / sqrt(1 + g), as the estimate reads it; none when the fit is
  // not well posed.
  std::optional<double> ResidualH(const Mesh& mesh, const Topology& topo, int32_t v, double h);

  // The median height above v (in the mesh's units) of its ring's inliers (the vertices not
  // flagged in `skip`, when at least three are not; else all of them), along the normal of the
  // plane that fits the inliers of its first and second rings, fitted again without the points
  // far off it (principal components: a dozen points or more, where the ring's own polygon leans
  // by tens of degrees when some of it is thrown); that normal into `axis`. None for a degenerate
  // ring.
  std::optional<double> RingHeight(const Vec3* pos, const Topology& topo, int32_t v, const uint8_t* skip,
                                   Vec3* axis = nullptr);

  // As RingHeight, along a plane that resists points thrown off it (a rim vertex's half ring,
  // where three thrown points in fifteen lean even the trimmed plane by ~45 degrees): least
  // median of squares, then least squares on the points within its robust scale or within a
  // mean edge `h` of it (where a curved surface's second ring lies).
  std::optional<double> RobustRingHeight(const Vec3* pos, const Topology& topo, int32_t v, double h,
                                         const uint8_t* skip, Vec3* axis = nullptr);

 private:
  struct Buffers;
  NoiseParams params_;
  std::unique_ptr<Buffers> buffers_;
};

}  // namespace meshsmooth
