// A smoothing job's options as the CLI's flags name them (the Python package's keyword
// parameters take the same names), checked as the service checks them and made into a JobSpec.
#pragma once

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/strength.h"
#include "meshsmooth/v1/smoothing.pb.h"

namespace meshsmooth::client {

// `meshsmooth smooth`; the flow options map onto JobSpec fields (0 or negative = unset).
struct SmoothOptions {
  std::string input, output;
  std::string flow;         // a name from FlowNames()
  unsigned iterations = 0;  // 0 = automatic (`--iterations auto`)
  double step = 0.0;
  std::string weights = "u0";
  double mu = 0.0, pass_band = 0.0, tangential_weight = -1.0, epsilon = 0.0;
  // Normal filter; 0 = the default (ListFlows).
  unsigned normal_iterations = 0, vertex_iterations = 0;
  double sigma_spatial = 0.0, sigma_range = 0.0;
  std::string adaptive = "none";
  double threshold = 0.0;
  unsigned recompute_every = 10;
  std::string boundary = "auto";
  double tolerance = 0.0;
  unsigned quantization_bits = 0;
  // --quantize-upload: the upload's positions quantized to this fraction of the input's mean edge
  // (client/upload_quantization.h); 0 = a lossless upload.
  double quantize_upload = 0.0;
  bool edgebreaker = false;
  bool gltf_draco = false;  // glTF output: Draco-compressed primitives
  bool quiet = false, json = false;
  bool ridges = false;
  double ridge_threshold = 0.0;
  std::string job_id;        // JobSpec.job_id; empty = the server makes one up
  StrengthOptions strength;  // --weight, --fixed, --region, --outside, --falloff
  // --max-displacement: D (mesh units) or Dh (D mean edge lengths); empty = no bound.
  std::string max_displacement;
  bool implicit = false;  // --implicit: JobSpec.integration IMPLICIT
  double theta = 0.0;     // --theta: JobSpec.theta; 0 = unset (backward Euler)
  // `meshsmooth enhance` (JobSpec.enhance): the job enhances instead of smoothing.
  bool enhance = false;
  double gain = 0.0;               // --gain: enhance.gain; 0 = unset (the default)
  std::string detail;              // --detail: D (mesh units) or Dh (mean edge lengths); empty = the default
  bool smooth_first = false;       // --smooth-first
  std::string method = "poisson";  // --method: poisson | inverted-flow
};

// A length option parsed (--max-displacement, --detail): the value and whether it is in mean
// edge lengths.
struct DisplacementBoundOption {
  double value = 0.0;
  bool in_h = false;
};

// "0.02" (mesh units) or "0.5h" (mean edge lengths of the input); empty = unset (0).
// InvalidArgument naming `flag` for anything else, a negative value, NaN or an infinity.
absl::StatusOr<DisplacementBoundOption> ParseLengthOption(const char* flag, const std::string& text);

// ParseLengthOption of --max-displacement (empty = no bound).
absl::StatusOr<DisplacementBoundOption> ParseMaxDisplacement(const std::string& text);

// The flow and output options of `meshsmooth smooth` checked as the server checks a JobSpec
// (server::FromProto), but for the iteration limit and the job id, which are the server's to
// judge, and the names of the flow, weights, adaptive mode and boundary mode too (the CLI's
// parser checks those first; a caller in code may not): InvalidArgument naming the parameter,
// before any file is read.
absl::Status CheckSmoothOptions(const SmoothOptions& options);

// The JobSpec of `options` (checked with CheckSmoothOptions first): the flow options (or, with
// options.enhance, JobSpec.enhance), the output encoding, the ridges and the strength's attribute
// name (kStrengthAttribute) when a strength is given by flags or `strength_values`.
v1::JobSpec SpecFrom(const SmoothOptions& options, bool strength_values = false);

}  // namespace meshsmooth::client
