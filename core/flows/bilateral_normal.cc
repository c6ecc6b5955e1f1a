// Bilateral normal filtering (Zheng, Fu, Au, Tai 2011, "Bilateral Normal Filtering for Mesh
// Denoising", its local iterative scheme), the two-step scheme of Belyaev and Ohtake (2003)
// and Sun et al. (2007) with a bilateral filter of the face normals:
//   n_i <- normalize( sum_{j in N(i)} A_j W_s(|c_i - c_j|) W_r(|n_i - n_j|) n_j )
// W_s, W_r Gaussians with sigma_s (relative to the mean distance between the centroids of
// faces sharing an edge) and sigma_r; N(i) the faces sharing a vertex with face i, i
// included; A_j the area and c_j the centroid of face j. Then the vertex update of
// normal_filtering.h. The range weight keeps the normals of the two sides of a crease apart,
// so creases stay sharp where every flow of the paper rounds them.
#include "core/flows/flow_table.h"
#include "core/flows/normal_filtering.h"

namespace meshsmooth::flows {
namespace {

class BilateralNormal final : public NormalFilterKernel {
 public:
  using NormalFilterKernel::NormalFilterKernel;

 protected:
  void FilterOnce(std::vector<Vec3>& out) override { Filter(normal_, out); }
};

std::unique_ptr<FlowKernel> MakeBilateralNormal(const FlowParams& p, double) {
  return std::make_unique<BilateralNormal>(p.normal_filter);
}

}  // namespace

FlowRow BilateralNormalRow() {
  return {FlowId::kBilateralNormal,
          "bilateral_normal",
          FlowKind::kNormalFilter,
          1.0,
          1.0,
          "Bilateral filtering of the face normals, then vertices fitted to them: removes noise and keeps "
          "sharp creases; one iteration = normal_iterations filter passes + vertex_iterations vertex updates",
          "Zheng et al. 2011 (docs/normal-filtering.md)",
          NormalFilterParameters(),
          {},
          ValidateNormalFilter,
          MakeBilateralNormal,
          PassReach::kMeanEdge};
}

}  // namespace meshsmooth::flows
