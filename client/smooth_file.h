// One input smoothed into one output, as `meshsmooth smooth IN -o OUT` does it and as each file
// of a batch is: the checks made before the input is read, the job in memory or through the
// service, the result written. Nothing here prints: the caller says what happened.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/commands.h"
#include "client/connection.h"
#include "client/job_run.h"
#include "meshsmooth/v1/smoothing.pb.h"

namespace meshsmooth::client {

// What a file's job tells its caller along the way (the job's own hooks, and these); any may be
// empty.
struct FileHooks : JobHooks {
  // Called with the CLI's warnings about the input, once it is read, before the job starts.
  std::function<void(const std::vector<std::string>&)> upload_warnings;
  std::function<void()> job_done;  // the job ended, before the result is written
  // A Ctrl-C watcher of its own around the job (a single run); a batch watches for all its jobs.
  bool watch_interrupt = false;
};

// How a file's job ended.
struct FileOutcome {
  int exit_code = 0;                         // 0, kExitFailure, kExitUnavailable or kExitInterrupted
  std::string error;                         // what failed, as "meshsmooth: " + error says it
  v1::Summary summary;                       // the job's
  std::vector<std::string> upload_warnings;  // the CLI's, about the input
  std::vector<std::string> dropped;          // what the output does not hold, one phrase each
  // With --quantize-upload: how the upload was quantized (DescribeUploadQuantization).
  std::string upload_note;
};

// The summary as --json gives it: the CLI's warnings (about the input, then "not kept: ..."; the
// upload's quantization, which changed the input, among them), then the job's summary with its own.
v1::Summary SummaryWithWarnings(const FileOutcome& outcome);

// True when --edgebreaker may encode the result of `input` written to `output`: a .drc or glTF
// output, or a .drc input (Edgebreaker reorders the points; any other output is written over the
// input's own faces in the input's order).
bool EdgebreakerFits(const std::string& input, const std::string& output);

// The checks of options.input and options.output made before the input is read, as a single
// run makes them: InvalidArgument with the message (exit 2) for a glTF input written to another
// format, --edgebreaker for an output written over the input's faces, an output CheckOutputPath
// refuses. A warning for `--ridges` with an output that does not keep them goes to `warnings`.
absl::Status CheckInputOutput(const SmoothOptions& options, std::vector<std::string>& warnings);

// Smooths options.input into options.output (checked with CheckInputOutput): in memory without
// --server where the output allows it, else through `service`; the job is registered with
// `cancels` while it runs.
FileOutcome SmoothFile(const SmoothOptions& options, ServiceLink& service, JobCancels& cancels, const FileHooks& hooks);

}  // namespace meshsmooth::client
