// The CLI's subcommands. main.cc turns the command line into these option structs; each Run*
// prints what the user asked for and returns the process's exit code.
#pragma once

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/connection.h"
#include "client/job_options.h"
#include "client/strength.h"

namespace meshsmooth::client {

// Exit codes (README, "The CLI").
inline constexpr int kExitFailure = 1;        // the job or the input failed
inline constexpr int kExitUsage = 2;          // bad command line
inline constexpr int kExitUnavailable = 3;    // the server could not be reached
inline constexpr int kExitInterrupted = 130;  // Ctrl-C (the job was cancelled on the server)

// `meshsmooth render`.
struct RenderCommand {
  std::string input = "builtin:noisy-sphere", output, view = "30,20", size = "800x800", shading = "gouraud";
  // When given, the vertices are coloured by this strength (StrengthColours) instead of their own colours.
  StrengthOptions strength;
};

// Smooths (or, with options.enhance, enhances) a mesh through the service and writes the
// result; prints the summary.
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
