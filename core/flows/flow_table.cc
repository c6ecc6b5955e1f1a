#include "core/flows/flow_table.h"

#include <cstdlib>

#include "core/flows/flow.h"

namespace meshsmooth {

const std::vector<FlowRow>& FlowTable() {
  static const std::vector<FlowRow>* const kTable = [] {
    auto* rows = new std::vector<FlowRow>{
#define MESHSMOOTH_FLOW_ROW(id, name) flows::name##Row(),
        MESHSMOOTH_FLOWS(MESHSMOOTH_FLOW_ROW)
#undef MESHSMOOTH_FLOW_ROW
    };
    for (size_t i = 0; i < rows->size(); ++i) {  // FlowOf() indexes by the enumerator
      if (static_cast<size_t>((*rows)[i].id) != i) std::abort();
    }
    return rows;
  }();
  return *kTable;
}

const FlowRow& FlowOf(FlowId id) { return FlowTable().at(static_cast<size_t>(id)); }

int PassesPerIteration(const FlowParams& p) {
  if (FlowOf(p.flow.value_or(kDefaultFlow)).kind != FlowKind::kNormalFilter) return 1;
  return p.normal_filter.normal_iterations + p.normal_filter.vertex_iterations;
}

namespace flows {

ParameterInfo WeightsParameter() {
  return {"weights", "umbrella operator: U0 uniform (eq. 3) or U1 inverse distance (eq. 4)", 0, 0, 0, false,
          false,     {"UMBRELLA_WEIGHTS_UNIFORM", "UMBRELLA_WEIGHTS_INVERSE_DISTANCE"}};
}

std::vector<ParameterInfo> NormalFilterParameters() {
  const NormalFilterParams d;
  return {{"normal_filter.normal_iterations",
           "filter passes over the face normals per iteration",
           static_cast<double>(d.normal_iterations),
           1,
           100,
           false,
           false,
           {}},
          {"normal_filter.vertex_iterations",
           "vertex updates fitting the faces to the filtered normals per iteration",
           static_cast<double>(d.vertex_iterations),
           1,
           100,
           false,
           false,
           {}},
          {"normal_filter.sigma_spatial",
           "spatial Gaussian sigma, relative to the mean distance between centroids of faces sharing an edge",
           d.sigma_spatial,
           0.0,
           10.0,
           true,
           false,
           {}},
          {"normal_filter.sigma_range",
           "range Gaussian sigma on the difference of unit normals |n_i - n_j|",
           d.sigma_range,
           0.0,
           2.0,
           true,
           false,
           {}}};
}

}  // namespace flows
}  // namespace meshsmooth
