// Guided mesh normal filtering (Zhang, Deng, Zhang, Bouaziz, Liu 2015, "Guided Mesh Normal
// Filtering", Pacific Graphics; its local scheme): the joint bilateral filter of the face normals
// whose range weight compares guidance normals g instead of the normals themselves,
//   n_i <- normalize( sum_{j in N(i)} A_j W_s(|c_i - c_j|) W_r(|g_i - g_j|) n_j ),
// with N(i), A_j, c_j, W_s and W_r as in bilateral_normal.cc. The guidance g_i is the
// area-weighted mean normal of the most consistent patch containing face i: the candidates are
// the patches P_j = N(j) of the faces j in N(i), and a patch's consistency is
//   H(P) = D(P) R(P),  D(P) = max_{a,b in P} |n_a - n_b|,
//   R(P) = max_{e in E(P)} phi(e) / (eps + sum_{e in E(P)} phi(e)),  phi(e) = |n_a - n_b|
// over the edges e inside P (faces a and b of P on its two sides), eps = 1e-9. A patch on one
// side of a crease has a small D; a patch across a crease whose normals change along one line
// has a small R. The authors' code (github.com/bldeng/GuidedDenoising,
// GuidedMeshNormalFiltering.cpp) was read for these definitions. Choices made here
// (docs/normal-filtering.md): N(i) is the faces sharing a vertex with face i rather than the
// paper's geometric radius of 2 mean centroid distances, the guidance is recomputed at every
// filter pass from that pass's normals, a patch whose mean normal is far from face i's is no
// guide for it (kMinGuideCosine), ties go to the patch of the smaller face index, and the vertex
// update and its guards are those of normal_filtering.h.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/flows/flow_table.h"
#include "core/flows/normal_filtering.h"

namespace meshsmooth::flows {
namespace {

// R(P)'s epsilon, as the authors' code: keeps the ratio finite on a flat patch.
constexpr double kSaliencyEpsilon = 1e-9;
// A patch is a guide for face i only when its mean normal lies within ~23 degrees of n_i
// (cos 23° = 0.92). At a corner every patch containing a face reaches onto the other sides,
// and the most consistent one can lie mostly there: its mean would pull the face onto the
// other side (a noisy cube's corner faces fold by ~89 degrees with any patch allowed, by 22
// at 30 degrees; 20-25 degrees keep every cube edge within 3 degrees of 90). With no such
// patch the face's own normal guides it, as in bilateral_normal.
constexpr double kMinGuideCosine = 0.92;

class GuidedNormal final : public NormalFilterKernel {
 public:
  using NormalFilterKernel::NormalFilterKernel;

 protected:
  void FilterOnce(std::vector<Vec3>& out) override {
    const int32_t nf = static_cast<int32_t>(graph_.faces.size());
    consistency_.resize(nf);
    patch_mean_.resize(nf);
    guide_.resize(nf);
    ForFaces([&](int32_t j) { Patch(j); });
    ForFaces([&](int32_t i) {
      double best = std::numeric_limits<double>::infinity();
      int32_t chosen = -1;
      for (int32_t k = graph_.offsets[i]; k < graph_.offsets[i + 1]; ++k) {
        const int32_t j = graph_.neighbours[k];
        if (area_[j] > 0.0 && consistency_[j] < best && Dot(patch_mean_[j], normal_[i]) >= kMinGuideCosine) {
          best = consistency_[j], chosen = j;
        }
      }
      guide_[i] = chosen < 0 ? normal_[i] : patch_mean_[chosen];
    });
    Filter(guide_, out);
  }

 private:
  // H(P_j) and the area-weighted mean normal of the patch P_j = N(j).
  void Patch(int32_t j) {
    const int32_t* const first = &graph_.neighbours[graph_.offsets[j]];
    const int32_t* const last = first + (graph_.offsets[j + 1] - graph_.offsets[j]);
    // The patch's normals side by side: D(P) compares every pair, from contiguous memory.
    thread_local std::vector<Vec3> normals;
    normals.clear();
    double most = 0.0, total = 0.0;
    Vec3 mean;
    for (const int32_t* a = first; a != last; ++a) {
      if (area_[*a] == 0.0) continue;  // no normal: not part of the patch's measures
      const Vec3 na = normal_[*a];
      normals.push_back(na);
      mean += na * area_[*a];
      for (int32_t other : graph_.across[*a]) {  // each inside edge once, from its smaller face
        if (other > *a && area_[other] > 0.0 && std::binary_search(first, last, other)) {
          const double phi = Norm(na - normal_[other]);
          most = std::max(most, phi);
          total += phi;
        }
      }
    }
    double spread = 0.0;
    const size_t m = normals.size();
    for (size_t a = 0; a < m; ++a) {
      for (size_t b = a + 1; b < m; ++b) spread = std::max(spread, SquaredNorm(normals[a] - normals[b]));
    }
    consistency_[j] = std::sqrt(spread) * (most / (kSaliencyEpsilon + total));
    const double len = Norm(mean);
    patch_mean_[j] = len > 0.0 ? mean * (1.0 / len) : normal_[j];
  }

  std::vector<double> consistency_;  // per face j: H(P_j)
  std::vector<Vec3> patch_mean_, guide_;
};

std::unique_ptr<FlowKernel> MakeGuidedNormal(const FlowParams& p, double) {
  return std::make_unique<GuidedNormal>(p.normal_filter);
}

}  // namespace

FlowRow GuidedNormalRow() {
  return {FlowId::kGuidedNormal,
          "guided_normal",
          FlowKind::kNormalFilter,
          1.0,
          1.0,
          "Guided filtering of the face normals (the range weight compares the mean normals of each "
          "face's most consistent patch), then vertices fitted to them: keeps the creases and corners of "
          "CAD parts; one iteration as bilateral_normal",
          "Zhang et al. 2015, eqs. (3)-(6) (docs/normal-filtering.md)",
          NormalFilterParameters(),
          {},
          ValidateNormalFilter,
          MakeGuidedNormal,
          PassReach::kMeanEdge};
}

}  // namespace meshsmooth::flows
