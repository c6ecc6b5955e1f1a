// Every knob of meshsmoothd in one place (flags in main.cc map onto these fields).
#pragma once

#include <cstdint>
#include <string>

namespace meshsmooth::server {

// How meshsmoothd writes its log on stderr: text lines for a terminal, or one JSON object a
// line for a log pipeline (server/log.h has the fields).
enum class LogFormat { kText, kJson };

struct ServerOptions {
  std::string listen = "127.0.0.1:50051";  // host:port; port 0 picks a free port
  int workers = 0;                         // smoothing jobs run at once; 0 = hardware threads
  int queue_depth = 64;                    // jobs waiting for a worker; beyond: RESOURCE_EXHAUSTED
  int threads_per_job = 0;                 // threads of one job's vertex loops; 0 = hardware threads
  int64_t max_upload_bytes = 512ll << 20;  // Draco bytes of one job
  int64_t max_vertices = 20'000'000;       // vertices of one mesh (after welding seams)
  int max_iterations = 10'000;
  // A job's memory by its estimate (server/job_memory.h) from the counts at the head of its
  // upload: above this, RESOURCE_EXHAUSTED before the rest of the upload is kept; 0 = no bound.
  int64_t max_job_bytes = 0;
  double max_job_seconds = 600.0;    // a job's time on its worker (decode to encode)
  int max_concurrent_streams = 128;  // Smooth calls open at once
  // An upload that receives no message for this long ends with DEADLINE_EXCEEDED, freeing its
  // call slot; <= 0: never. A 1 MiB chunk at 20 KiB/s still arrives within the default.
  double upload_idle_seconds = 60.0;
  // A job still waiting for a worker this long after its upload ends with RESOURCE_EXHAUSTED,
  // so that a client or balancer sends it to a replica with room; <= 0: it waits its turn.
  double max_queue_wait_seconds = 0.0;
  // Bytes held at once by uploads in flight and jobs waiting for a worker (their buffers'
  // capacity); an upload that would go beyond it gets RESOURCE_EXHAUSTED before keeping its
  // chunk. 0 = a quarter of the machine's memory (DefaultBufferedBytes()).
  int64_t max_buffered_bytes = 0;
  // On SIGTERM: running jobs get this long to finish; queued jobs and uploads end at once with
  // UNAVAILABLE, and the process exits by grace + 1 s whatever is left.
  double grace_seconds = 10.0;
  std::string tls_cert_file, tls_key_file;  // both or neither
  std::string auth_token;                   // non-empty: calls need "authorization: Bearer <token>"
  bool log_jobs = true;                     // one line per job on stderr
  bool log_refusals = true;                 // one line per refused call on stderr (not --quiet's)
  LogFormat log_format = LogFormat::kText;
  // The job store (smoothing.proto's Submit .. FetchResult, server/job_store.h): a directory
  // holding the SQLite database of jobs that outlive a connection, or a postgresql:// URI of a
  // database that replicas share; empty: no store, and those methods answer UNIMPLEMENTED.
  std::string job_store;
  // How long a running job stays this process's without a renewal (twice a second while it
  // runs): a replica that died leaves its jobs to the others this long after.
  double job_lease_seconds = 30.0;
  // An ended job and its bytes are forgotten this long after its end.
  double job_retention_seconds = 24 * 3600.0;
  // Bytes of uploads and results the job store may hold; an upload that does not fit, even after
  // forgetting ended jobs (oldest end first), gets RESOURCE_EXHAUSTED before any byte is kept.
  int64_t job_store_max_bytes = 10ll << 30;
  // The key of the completion callbacks' HMAC-SHA256 (JobSpec.callback_url, server/callbacks.h),
  // read from --callback-secret-file; empty: no callbacks, and a Submit naming one is refused.
  std::string callback_secret;
  // host:port of the Prometheus endpoint (GET /metrics; port 0 picks a free one); empty: none.
  std::string metrics_listen;
};

// Largest chunk a client may send; messages are limited to this plus framing.
inline constexpr int64_t kMaxChunkBytes = 1 << 20;
// Result chunks the server sends.
inline constexpr int64_t kResultChunkBytes = 1 << 20;

}  // namespace meshsmooth::server
