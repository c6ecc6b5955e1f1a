// What the CLI prints about a job and about the flows: progress on stderr, the summary and the
// flow list on stdout.
#pragma once

#include <string>

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

// The job summary as a before/after table, the displacement, features and timings.
void PrintSummary(const v1::Summary& summary);

// Every flow with its parameters, defaults and ranges, then the common parameters and the
// server's iteration limit.
void PrintFlows(const v1::ListFlowsResponse& flows);

}  // namespace meshsmooth::client
