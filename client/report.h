// What the CLI prints about a job and about the flows: progress on stderr, the summary and the
// flow list on stdout.
#pragma once

#include <chrono>
#include <string>

#include "absl/status/status.h"

#include "meshsmooth/v1/smoothing.pb.h"

namespace meshsmooth::client {

// Progress on stderr: a bar on a terminal, plain lines otherwise; nothing when quiet.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(bool quiet);
  void operator()(const v1::Progress& p);
  // Ends the bar's line, if a bar was drawn.
  void Done();

 private:
  bool quiet_, tty_, bar_shown_ = false;
  std::string smoothing_flow_;  // the flow of the smoothing phase reported last
};

// "meshsmooth: <prefix>attempt N failed (CODE: message); retrying in S s" on stderr.
void PrintRetry(const std::string& prefix, int retry, const absl::Status& status, std::chrono::milliseconds wait);

// The job summary as a before/after table, the displacement, features and timings.
void PrintSummary(const v1::Summary& summary);

// The job summary in one line: "FLOW, N iterations (stopped by WHY); displacement RMS R, max M".
std::string OneLineSummary(const v1::Summary& summary);

// Every flow with its parameters, defaults and ranges, then the common parameters and the
// server's iteration limit.
void PrintFlows(const v1::ListFlowsResponse& flows);

}  // namespace meshsmooth::client
