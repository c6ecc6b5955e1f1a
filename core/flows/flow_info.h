// Descriptions of the flows and their parameters, with defaults and valid ranges: the one
// source for the service's ListFlows and the CLI's help. Names are the JobSpec field names.
#pragma once

#include <string>
#include <vector>

namespace meshsmooth {

struct ParameterInfo {
  std::string name;
  std::string description;
  double default_value = 0.0;
  double min_value = 0.0;
  double max_value = 0.0;
  bool min_exclusive = false;
  bool max_exclusive = false;
  std::vector<std::string> choices;  // for enumerations
};

struct FlowInfo {
  std::string name;
  std::string description;
  std::string equations;
  std::vector<ParameterInfo> parameters;  // flow-specific, step first
  std::vector<std::string> constraints;   // between parameters, beyond their ranges
};

// Every flow, in FlowNames() order, from the flow table (core/flows/flow_table.h).
std::vector<FlowInfo> DescribeFlows();

// Parameters every flow takes: iterations, adaptive mode/threshold/interval, boundary,
// tolerance. `max_iterations` is the caller's limit.
std::vector<ParameterInfo> CommonParameters(int max_iterations);

}  // namespace meshsmooth
