// Conversions between meshsmooth.v1 messages and the core's structs, in one place.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/features/ridges.h"
#include "core/flows/catalogue.h"
#include "core/flows/flow.h"
#include "core/io/draco_codec.h"
#include "core/job/enhance.h"
#include "core/measure/metrics.h"
#include "core/topology.h"
#include "grpcpp/support/status.h"
#include "meshsmooth/v1/smoothing.pb.h"

namespace meshsmooth::server {

// The flow parameters and output options a JobSpec asks for, defaults filled in.
struct JobParams {
  FlowParams flow;
  DracoOptions output;
  bool detect_features = false;
  FeatureOptions features;
  std::string job_id;  // the client's JobSpec.job_id (checked); empty = the server makes one up
  // JobSpec.strength_attribute: the upload's attribute that fills flow.strength; empty = none.
  std::string strength_attribute;
  // JobSpec.enhance: the job enhances with these instead of smoothing with `flow` (whose
  // strength and threads it takes); unset = a smoothing job.
  std::optional<EnhanceParams> enhance;
};

// JobSpec.job_id's longest length.
inline constexpr size_t kMaxJobIdLength = 128;

// OK for a JobSpec.job_id the server takes: at most kMaxJobIdLength characters of printable
// ASCII without spaces (empty: the server makes one up); else InvalidArgument naming job_id.
absl::Status CheckJobId(const std::string& id);

// Ridges and ravines a job found (Features without the per-vertex data).
struct FeatureSummary {
  int64_t ridges = 0, ravines = 0, classified = 0;
  double detect_seconds = 0.0;
};

// What a job measured as it ran: the one source of its summary and of its log line.
struct JobReport {
  std::string job_id;
  std::string status = "OK";  // the status code's name when the job failed
  std::string error;          // the status message when the job failed
  int64_t vertices = 0;       // of the welded mesh; 0 when it did not decode
  FlowResult flow;            // iterations_run: those completed, also when the run ends early
  // An enhancement job's, once it ran (flow is then its smoothing first, if any).
  std::optional<EnhanceResult> enhanced;
  double decode_seconds = 0.0, queue_seconds = 0.0, smooth_seconds = 0.0, encode_seconds = 0.0;
  double total_seconds = 0.0;  // from the call's arrival
  // Known once the job got that far.
  MeshMetrics before, after;
  std::optional<Displacement> displacement;
  std::optional<FeatureSummary> features;  // when the spec asked for them
  uint64_t result_bytes = 0;
  std::vector<std::string> warnings;  // Summary.warnings
};

// The summary of a job that succeeded.
v1::Summary MakeSummary(const JobReport& report, const JobParams& params);

// The flow a job's log line and metrics name: the one that ran (a default job's choice) once it
// iterated; else the one asked for; "enhance" for an enhancement job.
std::string_view JobFlowName(const JobReport& report, const JobParams& params);

// The job's log line, without a newline: "meshsmoothd job=ID flow=NAME vertices=N
// iterations=RUN/ASKED status=CODE decode=Ss queue=Ss smooth=Ss encode=Ss", then " peer=PEER"
// when `peer` is given and, for a failed job, " error=\"MESSAGE\"" (quoted as a JSON string).
std::string JobLogLine(const JobReport& report, const JobParams& params, std::string_view peer = {});

// InvalidArgument naming the field for anything out of range (iterations above
// `max_iterations` included) and for enum values this server does not know; the flow's own
// checks run here too, so a bad spec is refused before the upload.
absl::StatusOr<JobParams> FromProto(const v1::JobSpec& spec, int max_iterations);

// The one place an absl::Status becomes a grpc::Status: the codes share their numbers; messages
// beyond 2,000 characters are cut so a status stays small.
grpc::Status ToGrpc(const absl::Status& s);

void ToProto(const ValidationReport& r, v1::ValidationReport* out);
void ToProto(const MeshMetrics& m, v1::MeshMetrics* out);
v1::ProgressPhase ToProto(Phase phase);
void ToProto(const Progress& p, v1::Progress* out);
void ToProto(const ParameterInfo& p, v1::ParameterInfo* out);
void ToProto(const JobParams& params, const FlowResult& result, v1::EffectiveParameters* out);

// "SUCCEEDED" for JOB_STATE_SUCCEEDED: a kept job's state in the log and in its callback.
std::string JobStateName(v1::JobState state);

}  // namespace meshsmooth::server
