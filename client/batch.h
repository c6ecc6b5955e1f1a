// `meshsmooth smooth` over many files: `meshsmooth smooth DIR_OR_GLOB... -o OUTDIR` (or
// `--batch FILE`), N files in flight over one connection, each file's failure its own.
#pragma once

#include <string>
#include <vector>

#include "client/commands.h"
#include "client/connection.h"

namespace meshsmooth::client {

// The options only a batch has, and its inputs as the command line gave them.
struct BatchOptions {
  std::vector<std::string> inputs;  // files, folders, glob patterns, builtin:NAME
  std::string list_file;            // --batch: one input a line; "-" = standard input
  std::string format;               // --format: the outputs' extension; empty = each input's own
  int jobs = 1;                     // --jobs: files in flight at once
};

// The upper bound of --jobs.
inline constexpr int kMaxBatchJobs = 64;

// Runs the batch `batch` with the smooth options of every file (`options.input` and
// `options.output` aside: -o is the output folder, in `options.output`). Refuses with kExitUsage,
// before any job, what cannot be a batch (BatchPlan's refusals, glTF inputs, --edgebreaker for a
// file written over its input's faces). Then smooths every file, `batch.jobs` at once, through
// one channel to --server (or in this process), and prints a progress line per file on stderr
// and a summary line per file and a total on stdout (--json: a JSON object per line; --quiet:
// neither). Returns 0 when every file was smoothed; kExitInterrupted after Ctrl-C (the jobs in
// flight cancelled, no new one started); kExitUnavailable when no file was smoothed because the
// server could not be reached; kExitFailure when any file failed, after a message naming each
// failed file with its error.
int RunBatch(const SmoothOptions& options, const ConnectionOptions& connection, const BatchOptions& batch);

}  // namespace meshsmooth::client
