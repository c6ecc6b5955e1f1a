#include "core/flows/flow_table.h"

#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/flows/flow.h"
#include "core/flows/flow_kernel.h"

namespace meshsmooth {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

ParameterInfo Weights() {
  return {"weights", "umbrella operator: U0 uniform (eq. 3) or U1 inverse distance (eq. 4)", 0, 0, 0, false, false,
          {"UMBRELLA_WEIGHTS_UNIFORM", "UMBRELLA_WEIGHTS_INVERSE_DISTANCE"}};
}

// The parameters of the normal-filtering flows (FlowParams::normal_filter; JobSpec.normal_filter).
std::vector<ParameterInfo> NormalFilterParameters(const NormalFilterParams& d) {
  return {{"normal_filter.normal_iterations", "filter passes over the face normals per iteration",
           static_cast<double>(d.normal_iterations), 1, 100, false, false, {}},
          {"normal_filter.vertex_iterations", "vertex updates fitting the faces to the filtered normals per iteration",
           static_cast<double>(d.vertex_iterations), 1, 100, false, false, {}},
          {"normal_filter.sigma_spatial",
           "spatial Gaussian sigma, relative to the mean distance between centroids of faces sharing an edge",
           d.sigma_spatial, 0.0, 10.0, true, false, {}},
          {"normal_filter.sigma_range", "range Gaussian sigma on the difference of unit normals |n_i - n_j|",
           d.sigma_range, 0.0, 2.0, true, false, {}}};
}

std::vector<FlowRow> MakeTable() {
  const FlowParams d;
  std::vector<FlowRow> rows;
  rows.push_back({FlowId::kLaplacian, "laplacian", FlowKind::kUmbrella, 0.5, 1.0,
                  "Laplacian smoothing: regularises the sampling but shrinks and flattens", "eqs. (2)-(4)",
                  {Weights()}, {}, nullptr, flows::MakeLaplacian});
  rows.push_back({FlowId::kTaubin, "taubin", FlowKind::kUmbrella, 0.5, 1.0,
                  "Taubin lambda|mu smoothing: no shrinkage, but turns noise into low-frequency waves; one "
                  "iteration is a lambda pass and a mu pass",
                  "eq. (6)",
                  {Weights(),
                   {"taubin_mu", "mu (> lambda, <= 1); unset = from the pass band", 0.0, 0.0, 1.0, true, false, {}},
                   {"taubin_pass_band", "k_PB = 1/lambda - 1/mu, used when mu is unset", d.taubin_pass_band, 0.0, kInf,
                    true, true, {}}},
                  {"taubin_mu set: step < taubin_mu <= 1",
                   "taubin_mu unset: 0 < taubin_pass_band < 1/step - 1 (so step < 1 / (1 + taubin_pass_band))"},
                  flows::ValidateTaubin, flows::MakeTaubin});
  rows.push_back({FlowId::kBilaplacian, "bilaplacian", FlowKind::kUmbrella, 0.2, 0.5,
                  "Bilaplacian flow P -= lambda U0^2(P): smooth, slight deformation",
                  "Section 2 (sign: docs/paper.md)", {}, {}, nullptr, flows::MakeBilaplacian});
  rows.push_back({FlowId::kMcf, "mcf", FlowKind::kCurvature, 0.1, 10.0,
                  "Mean curvature flow with cotangent weights: smooths well, sampling gets irregular", "eqs. (7)-(8)",
                  {}, {}, nullptr, flows::MakeMcf});
  rows.push_back({FlowId::kMcfTangential, "mcf_tangential", FlowKind::kCurvature, 0.1, 10.0,
                  "Mean curvature flow plus a tangential umbrella that evens out the sampling", "eq. (11)",
                  {{"tangential_weight", "C: the tangential part moves a vertex by step * C * U0_t (step * C <= 1)",
                    d.tangential_weight, 0.0, kInf, false, true, {}}},
                  {"step * tangential_weight <= 1"}, flows::ValidateMcfTangential, flows::MakeMcfTangential});
  rows.push_back({FlowId::kMedian, "median", FlowKind::kCurvature, 0.1, 10.0,
                  "The paper's flow: moves along the umbrella direction with normal speed equal to the mean "
                  "curvature; smooths like mcf and keeps the mesh regular",
                  "eqs. (12)-(13)",
                  {{"epsilon", "vertices with |cos(theta)| <= epsilon do not move", d.epsilon, 0.0, 1.0, true, true, {}}},
                  {}, nullptr, flows::MakeMedian});
  rows.push_back({FlowId::kBilateralNormal, "bilateral_normal", FlowKind::kNormalFilter, 1.0, 1.0,
                  "Bilateral filtering of the face normals, then vertices fitted to them: removes noise and keeps "
                  "sharp creases; one iteration = normal_iterations filter passes + vertex_iterations vertex updates",
                  "Zheng et al. 2011 (docs/normal-filtering.md)", NormalFilterParameters(d.normal_filter), {},
                  flows::ValidateNormalFilter, flows::MakeBilateralNormal});
  rows.push_back({FlowId::kGuidedNormal, "guided_normal", FlowKind::kNormalFilter, 1.0, 1.0,
                  "Guided filtering of the face normals (the range weight compares the mean normals of each "
                  "face's most consistent patch), then vertices fitted to them: keeps the creases and corners of "
                  "CAD parts; one iteration as bilateral_normal",
                  "Zhang et al. 2015, eqs. (3)-(6) (docs/normal-filtering.md)", NormalFilterParameters(d.normal_filter),
                  {}, flows::ValidateNormalFilter, flows::MakeGuidedNormal});
  return rows;
}

}  // namespace

const std::vector<FlowRow>& FlowTable() {
  static const std::vector<FlowRow>* const kTable = [] {
    auto* rows = new std::vector<FlowRow>(MakeTable());
    for (size_t i = 0; i < rows->size(); ++i) {  // FlowOf() indexes by the enumerator
      if (static_cast<size_t>((*rows)[i].id) != i) std::abort();
    }
    return rows;
  }();
  return *kTable;
}

const FlowRow& FlowOf(FlowId id) { return FlowTable().at(static_cast<size_t>(id)); }

absl::StatusOr<FlowId> ParseFlowName(std::string_view name) {
  for (const FlowRow& row : FlowTable()) {
    if (row.name == name) return row.id;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown flow '", std::string(name), "' (", absl::StrJoin(FlowNames(), ", "), ")"));
}

const std::vector<std::string>& FlowNames() {
  static const std::vector<std::string>* const kNames = [] {
    auto* names = new std::vector<std::string>;
    for (const FlowRow& row : FlowTable()) names->emplace_back(row.name);
    return names;
  }();
  return *kNames;
}

double DefaultStep(FlowId flow) { return FlowOf(flow).default_step; }

int PassesPerIteration(const FlowParams& p) {
  if (FlowOf(p.flow).kind != FlowKind::kNormalFilter) return 1;
  return p.normal_filter.normal_iterations + p.normal_filter.vertex_iterations;
}

}  // namespace meshsmooth
