// The CLI's subcommands. main.cc turns the command line into these option structs; each Run*
// prints what the user asked for and returns the process's exit code.
#pragma once

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/connection.h"
#include "client/strength.h"

namespace meshsmooth::client {

// Exit codes (README, "The CLI").
inline constexpr int kExitFailure = 1;        // the job or the input failed
inline constexpr int kExitUsage = 2;          // bad command line
inline constexpr int kExitUnavailable = 3;    // the server could not be reached
inline constexpr int kExitInterrupted = 130;  // Ctrl-C (the job was cancelled on the server)

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
  bool edgebreaker = false;
  bool gltf_draco = false;  // glTF output: Draco-compressed primitives
  bool quiet = false, json = false;
  bool ridges = false;
  double ridge_threshold = 0.0;
  std::string job_id;        // JobSpec.job_id; empty = the server makes one up
  StrengthOptions strength;  // --weight, --fixed, --region, --outside, --falloff
  // --max-displacement: D (mesh units) or Dh (D mean edge lengths); empty = no bound.
  std::string max_displacement;
};

// --max-displacement parsed: the bound and whether it is in mean edge lengths.
struct DisplacementBoundOption {
  double value = 0.0;
  bool in_h = false;
};

// "0.02" (mesh units) or "0.5h" (mean edge lengths of the input); empty = no bound (0).
// InvalidArgument naming --max-displacement for anything else, a negative value, NaN or an
// infinity.
absl::StatusOr<DisplacementBoundOption> ParseMaxDisplacement(const std::string& text);

// `meshsmooth render`.
struct RenderCommand {
  std::string input = "builtin:noisy-sphere", output, view = "30,20", size = "800x800", shading = "gouraud";
  // When given, the vertices are coloured by this strength (StrengthColours) instead of their own colours.
  StrengthOptions strength;
};

// The flow and output options of `meshsmooth smooth` checked as the server checks a JobSpec
// (server::FromProto), but for the iteration limit and the job id, which are the server's to
// judge: InvalidArgument naming the parameter, before any file is read.
absl::Status CheckSmoothOptions(const SmoothOptions& options);

// Smooths a mesh through the service and writes the result; prints the summary.
int RunSmooth(const SmoothOptions& options, const ConnectionOptions& connection);

// Lists the flows the service offers (ListFlows), as text or as JSON.
int RunFlows(const ConnectionOptions& connection, bool json);

// A mesh's validation report and metrics, computed locally.
int RunInfo(const std::string& input);

// Ridges and ravines of a mesh as it is (no smoothing), written as PLY vertex colours.
// `threshold`: "auto" (FeatureOptions::relative_threshold = kDefaultRelativeThreshold) or an
// absolute |curvature| >= 0.
int RunRidges(const std::string& input, const std::string& output, const std::string& threshold);

// A picture of a mesh, rendered locally into a PNG.
int RunRender(const RenderCommand& command);

}  // namespace meshsmooth::client
