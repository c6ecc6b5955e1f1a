// meshsmoothd's Prometheus metrics, in one place (metrics.cc has every name, label and bucket).
//
// The service reports events through ServiceMetrics, which knows nothing of prometheus-cpp: with
// --metrics-listen off it gets NoMetrics(), whose calls do nothing. MetricsExporter is the
// Prometheus side: it counts the events, reads the service's gauges (queue, running jobs, held
// bytes) and the process's CPU and memory from /proc at each scrape, and serves GET /metrics.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "server/convert.h"

namespace meshsmooth::server {

// Why a call ended before its job could run (or, for kQueueWait, while it waited for a worker).
enum class Refusal : uint8_t {
  kQueueFull,        // the worker pool's queue was full (--queue-depth)
  kQueueWait,        // the job waited longer than --max-queue-wait
  kMemoryBudget,     // the upload did not fit in --max-buffered-bytes
  kUploadTooLarge,   // the upload passed --max-upload-bytes
  kChunkTooLarge,    // a mesh chunk above the per-chunk limit
  kTooManyCalls,     // more than --max-concurrent-streams Smooth calls open
  kUploadIdle,       // the upload sent nothing for --upload-idle-seconds
  kShuttingDown,     // the server was draining: the job did not start
  kUnauthenticated,  // no or a wrong bearer token
  kInvalidRequest,   // the call broke the protocol or its spec was refused
  kJobTooLarge,      // the job's memory estimate was above --max-job-bytes
};
inline constexpr int kRefusalCount = 11;

// The `reason` label of a refusal: "queue_full", "queue_wait", "memory_budget",
// "upload_too_large", "chunk_too_large", "too_many_calls", "upload_idle", "shutting_down",
// "unauthenticated", "invalid_request", "job_too_large".
std::string_view RefusalName(Refusal reason);

// What the service tells its metrics. Called from gRPC's and the workers' threads at once.
class ServiceMetrics {
 public:
  virtual ~ServiceMetrics() = default;
  // A job a worker took has ended, whatever its status (report.status): once per job.
  virtual void JobEnded(const JobReport& report, const JobParams& params) = 0;
  virtual void Refused(Refusal reason) = 0;
  // Mesh bytes of an upload, as each chunk is kept.
  virtual void UploadReceived(int64_t bytes) = 0;
  // Bytes of a Submit chunk (a kept job's upload), as it arrives, before the store checks it.
  virtual void JobUploadReceived(int64_t bytes) = 0;
};

// The metrics of a server without --metrics-listen: every call does nothing.
ServiceMetrics& NoMetrics();

// The service's state, read at each scrape.
struct ServiceGauges {
  int64_t queued_jobs = 0;     // waiting for a worker
  int64_t running_jobs = 0;    // on a worker
  int64_t buffered_bytes = 0;  // held against --max-buffered-bytes
  int64_t buffered_bytes_limit = 0;
  int64_t workers = 0;         // --workers in effect
  int64_t queue_capacity = 0;  // --queue-depth
  // With a job store (--job-store): its jobs by state (index: v1::JobState; the whole store, so
  // every replica on one PostgreSQL reports the same), the age of its oldest QUEUED job, and
  // the jobs this process claimed after another run's lease had run out.
  bool job_store = false;
  std::array<int64_t, 6> stored_jobs{};
  double oldest_queued_seconds = 0.0;  // 0 when none is queued
  int64_t lease_takeovers = 0;
};

class MetricsExporter {
 public:
  // Serves GET /metrics on `listen` (host:port; port 0 picks a free one). FailedPrecondition when
  // the address cannot be bound.
  static absl::StatusOr<std::unique_ptr<MetricsExporter>> Start(const std::string& listen);
  ~MetricsExporter();  // stops serving

  int port() const;
  ServiceMetrics& events();
  // Where a scrape reads the service's gauges; nullptr (before the service exists and after it
  // is gone) exports none of them.
  void SetGaugeSource(std::function<ServiceGauges()> source);

 private:
  struct State;
  explicit MetricsExporter(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

// A process's CPU and memory as Prometheus's client libraries export them
// (process_cpu_seconds_total, process_resident_memory_bytes, ...).
struct ProcessSamples {
  double cpu_seconds = 0.0;  // user + system
  double resident_memory_bytes = 0.0;
  double virtual_memory_bytes = 0.0;
  double start_time_seconds = 0.0;  // since the Unix epoch
  double open_fds = 0.0;
  double max_fds = 0.0;  // the soft limit
};

// Reads them from `proc` (a /proc/<pid> folder: stat, fd/, limits) and `proc_stat` (/proc/stat,
// for the boot time); nullopt when `proc`/stat cannot be read or parsed.
std::optional<ProcessSamples> ReadProcessSamples(const std::string& proc = "/proc/self",
                                                 const std::string& proc_stat = "/proc/stat");

}  // namespace meshsmooth::server
