// Ridge and ravine vertices, Section 5 of the paper (docs/paper.md, "Ridges and ravines", says
// what the code chose where the paper is silent): a ridge is where the maximal
// principal curvature attains a positive maximum along its curvature line, a ravine where the
// minimal principal curvature attains a negative minimum along its curvature line. The paper
// smooths the mesh first (e.g. Smooth() with flow "median") and then detects.
#pragma once

#include <cstdint>
#include <vector>

#include "core/features/curvature.h"
#include "core/io/draco_codec.h"
#include "core/mesh.h"
#include "core/topology.h"
#include "core/util/stop_token.h"

namespace meshsmooth {

enum class FeatureLabel : uint8_t { kNone = 0, kRidge = 1, kRavine = 2 };

struct FeatureOptions {
  // A vertex whose |kappa| (kmax for a ridge, kmin for a ravine) is at or below this is not a
  // feature; absolute, in 1/mesh units. 0 keeps every strict extremum of the right sign.
  double min_abs_curvature = 0.0;
  // > 0: the threshold is also at least this share of the mesh's own curvature scale, the 90th
  // percentile of max(|kmax|, |kmin|) (the ring means compared) over the classified vertices: a
  // threshold that follows the mesh's size and shape, so that the estimate's scatter where a
  // principal curvature is zero (a cylinder's axis, a wave's flanks) is not labelled.
  double relative_threshold = 0.0;
};

// The share of the curvature scale `meshsmooth ridges` uses when given no threshold.
inline constexpr double kDefaultRelativeThreshold = 0.1;

struct Features {
  CurvatureField curvature;     // EstimateCurvature() of the mesh
  std::vector<uint8_t> labels;  // a FeatureLabel per vertex
  int64_t ridges = 0, ravines = 0;
  int64_t classified = 0;  // vertices with a curvature estimate (valid)
  double threshold = 0.0;  // the |kappa| threshold applied, in 1/mesh units
};

// Labels every vertex of `mesh` (`topology` = BuildTopology(mesh)), Section 5 of the paper.
// The values compared are ring means of EstimateCurvature()'s kmax and kmin (positive where the
// surface bends away from the normal): at a vertex with an estimate, the mean over it and its
// neighbours that have one (a one-ring filter of the estimate's scatter on irregular meshes); at
// one without, the mean over its neighbours that have one. A vertex P with an estimate is a
// ridge vertex when its mean kmax is > 0 and > min_abs_curvature and exceeds its linear
// interpolation at both points where the plane through P spanned by the normal and dir_max cuts
// the one-ring polygon (along each crossed ring edge from its end points that have a value; on
// each side of P the nearest crossing that has one counts). A ravine vertex likewise has mean
// kmin < 0, -kmin > min_abs_curvature and kmin below its interpolations along the plane of the
// normal and dir_min. A vertex that is both gets the label of the larger |kappa|. Not
// classified (kNone): vertices without an estimate (boundary, non-manifold, isolated,
// degenerate) and vertices whose plane finds no value on one side of the ring; a poor neighbour
// does not stop a vertex from being classified. O(n), deterministic for any thread count. Once
// `stop` fires the vertices left are not classified: a caller that passes a token checks it.
Features DetectFeatures(const Mesh& mesh, const Topology& topology, const FeatureOptions& options = {},
                        const StopToken& stop = {});

// Names of the generic Draco attributes a smoothing job with feature detection returns (part
// of the meshsmooth.v1 contract, see FeatureDetection in proto/meshsmooth/v1/smoothing.proto).
inline constexpr char kFeatureLabelAttribute[] = "feature_label";
inline constexpr char kKmaxAttribute[] = "kmax";
inline constexpr char kKminAttribute[] = "kmin";

// The labels (uint8) and kmax, kmin (float32) as those three attributes.
std::vector<GenericAttribute> FeatureAttributes(const Features& features);

// Vertex colours of the paper's Fig. 11: ridges black, ravines white, everything else light
// grey (200, 200, 200; light enough that black lines stand out once shaded).
std::vector<Rgb> FeatureColors(const std::vector<uint8_t>& labels);

}  // namespace meshsmooth
