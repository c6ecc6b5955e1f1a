// The CLI's commands for jobs kept in a server's job store (smoothing.proto, Submit ..
// FetchResult; meshsmoothd --job-store): submit, status, watch, fetch, cancel, jobs. A broken
// connection during an upload, a watch or a download resumes where it stopped, up to --retries
// times.
#pragma once

#include <string>

#include "client/connection.h"

namespace meshsmooth::client {

struct JobCommand {
  std::string input;             // submit: the mesh file (or builtin:NAME)
  std::string output;            // fetch (and submit --wait): the result's .drc file
  std::string job_id;            // status, watch, fetch, cancel
  std::string request_id;        // submit; empty = the SHA-256 of the spec and the upload (the same job again)
  std::string flow;              // submit: JobSpec.flow; empty = the default job
  unsigned iterations = 0;       // submit: JobSpec.iterations; 0 = automatic
  std::string callback_url;      // submit: JobSpec.callback_url; empty = none
  bool wait = false;             // submit: watch to the end, then fetch into `output`
  double quantize_upload = 0.0;  // submit: --quantize-upload's fraction of the mean edge; 0 = lossless
  std::string state;             // jobs: only this state (queued, running, succeeded, failed, cancelled)
};

// `meshsmooth submit IN`: uploads (resuming a broken upload), prints the job id; with --wait
// watches the job and fetches its result into -o.
int RunSubmit(const JobCommand& command, const ConnectionOptions& connection);
// `meshsmooth status ID`: the job's state, progress, times and, when it ended, its summary or error.
int RunStatus(const JobCommand& command, const ConnectionOptions& connection);
// `meshsmooth watch ID`: a line per event to the job's end; exit 0 for SUCCEEDED, 1 otherwise.
int RunWatch(const JobCommand& command, const ConnectionOptions& connection);
// `meshsmooth fetch ID -o OUT.drc`: the result, resumed from the bytes written after a broken
// download, checked against its SHA-256.
int RunFetch(const JobCommand& command, const ConnectionOptions& connection);
// `meshsmooth cancel ID`.
int RunCancel(const JobCommand& command, const ConnectionOptions& connection);
// `meshsmooth jobs`: one line per job, oldest first.
int RunJobs(const JobCommand& command, const ConnectionOptions& connection);

}  // namespace meshsmooth::client
