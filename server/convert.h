// Conversions between meshsmooth.v1 messages and the core's structs, in one place.
#pragma once

#include "absl/status/statusor.h"
#include "core/draco_codec.h"
#include "core/features/ridges.h"
#include "core/flows/flow.h"
#include "core/flows/flow_info.h"
#include "core/metrics.h"
#include "core/topology.h"
#include "meshsmooth/v1/smoothing.pb.h"

namespace meshsmooth::server {

// The flow parameters and output options a JobSpec asks for, defaults filled in.
struct JobParams {
  FlowParams flow;
  DracoOptions output;
  bool detect_features = false;
  FeatureOptions features;
};

// InvalidArgument naming the field for anything out of range (iterations above
// `max_iterations` included); the flow's own checks run here too, so a bad spec is refused
// before the upload.
absl::StatusOr<JobParams> FromProto(const v1::JobSpec& spec, int max_iterations);

void ToProto(const ValidationReport& r, v1::ValidationReport* out);
void ToProto(const MeshMetrics& m, v1::MeshMetrics* out);
void ToProto(const Progress& p, v1::Progress* out);
void ToProto(const ParameterInfo& p, v1::ParameterInfo* out);
void ToProto(const JobParams& params, const FlowResult& result, v1::EffectiveParameters* out);

}  // namespace meshsmooth::server
