// Admission: which calls a server takes and how long it keeps them, in one place, with every
// RESOURCE_EXHAUSTED and UNAVAILABLE text the service sends.
//   - Open calls: at most --max-concurrent-streams Smooth calls at a time (Admission::Open).
//   - Memory: a server-wide budget for the bytes held by uploads in flight and by jobs waiting
//     for a worker (MemoryBudget). An upload takes its buffer's bytes before it keeps a chunk
//     and is refused when they do not fit; a job gives them back once its upload is decoded
//     and freed. Running jobs' meshes are not counted: the number of workers bounds them.
//   - A job's memory: from the counts at the head of its upload, before the rest is kept, a job
//     whose estimate (job_memory.h) is above --max-job-bytes is refused (CheckJobMemory).
//   - Draining: once shutdown begins, new calls, uploads and queued jobs end with UNAVAILABLE
//     at once (safe to send elsewhere); running jobs get the grace period.
//   - Time: an upload that sends nothing for --upload-idle-seconds and a job that waits longer
//     than --max-queue-wait for a worker end (the reaper thread).
// The queue's depth itself is the worker pool's (worker_pool.h); its refusal text is here.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <thread>
#include <utility>

#include "absl/status/status.h"
#include "grpcpp/support/status.h"
#include "server/convert.h"
#include "server/metrics.h"
#include "server/options.h"

namespace meshsmooth::server {

// A call the server refuses: why (the metrics' `reason` label and the log's) and the status it
// ends with.
struct Refused {
  Refusal reason;
  grpc::Status status;
};

// True for a refusal that is the server's capacity at the moment (a full queue, too many open
// calls, the memory budget, the queue wait): a retry later or on another replica can succeed.
// False for every other one, and a RESOURCE_EXHAUSTED of any other origin (a limit the request
// exceeds: --max-upload-bytes, --max-vertices, the chunk size, quadratic work) fails again.
bool IsTransient(Refusal reason);

// Trailing metadata of every RESOURCE_EXHAUSTED a Smooth call ends with, which smoothing.proto
// documents for clients: kExhaustedTransient when IsTransient() holds, else kExhaustedPermanent.
inline constexpr char kExhaustedKey[] = "meshsmooth-exhausted";
inline constexpr char kExhaustedTransient[] = "transient";
inline constexpr char kExhaustedPermanent[] = "permanent";

class MemoryBudget {
 public:
  explicit MemoryBudget(int64_t limit) : limit_(limit) {}
  MemoryBudget(const MemoryBudget&) = delete;
  MemoryBudget& operator=(const MemoryBudget&) = delete;

  // Takes `bytes` when they fit under the limit; false (nothing taken) when they do not.
  bool TryTake(int64_t bytes);
  void Give(int64_t bytes);
  int64_t held() const;
  int64_t limit() const { return limit_; }

 private:
  const int64_t limit_;
  mutable std::mutex mu_;
  int64_t held_ = 0;
};

// Bytes taken from a MemoryBudget by one upload, given back when released or destroyed; it
// moves with the upload from the call to its job.
class BudgetHold {
 public:
  BudgetHold() = default;
  explicit BudgetHold(MemoryBudget* budget) : budget_(budget) {}
  BudgetHold(BudgetHold&& other) noexcept;
  BudgetHold& operator=(BudgetHold&& other) noexcept;
  ~BudgetHold() { Release(); }

  // Takes `bytes` more; false (nothing taken) when the budget has no room for them.
  bool TryGrow(int64_t bytes);
  // Gives everything back.
  void Release();
  int64_t bytes() const { return bytes_; }

 private:
  MemoryBudget* budget_ = nullptr;
  int64_t bytes_ = 0;
};

// One call's upload: its bytes, in a buffer that grows geometrically (appends stay linear) and
// whose capacity is held against the budget.
class UploadBuffer {
 public:
  UploadBuffer(MemoryBudget* budget, int64_t max_bytes, ServiceMetrics& metrics = NoMetrics())
      : hold_(budget), budget_(budget), max_bytes_(max_bytes), metrics_(metrics) {}

  // Appends `chunk` and counts its bytes in the metrics; nullopt then. A RESOURCE_EXHAUSTED
  // refusal, keeping nothing of it, when the upload would pass `max_bytes` (kUploadTooLarge)
  // or the budget has no room for the buffer it needs (kMemoryBudget).
  std::optional<Refused> Append(std::string_view chunk);
  bool empty() const { return bytes_.empty(); }
  std::string_view bytes() const { return bytes_; }
  // The bytes and their hold, for the job; the buffer is empty afterwards.
  std::string TakeBytes() { return std::exchange(bytes_, std::string()); }
  BudgetHold TakeHold() { return std::move(hold_); }

 private:
  std::string bytes_;
  BudgetHold hold_;  // bytes_'s capacity
  MemoryBudget* budget_;
  int64_t max_bytes_;
  ServiceMetrics& metrics_;
};

// The default of --max-buffered-bytes: a quarter of the machine's memory (MemTotal in
// /proc/meminfo), or 4 GiB where that cannot be read. A quarter leaves the rest for the running
// jobs, whose decoded meshes take several times their compressed upload.
int64_t DefaultBufferedBytes(const std::string& meminfo_path = "/proc/meminfo");

// A call that Admission keeps track of (the Smooth reactor). Called from the reaper's and the
// shutdown's threads, under Admission's lock: none may call back into Admission.
class AdmittedCall {
 public:
  using Clock = std::chrono::steady_clock;
  virtual ~AdmittedCall() = default;
  // True while the call still reads its upload and its last message arrived before `cutoff`.
  virtual bool IdleSince(Clock::time_point cutoff) const = 0;
  // True while the call's job waits in the queue and was queued before `cutoff`.
  virtual bool QueuedSince(Clock::time_point cutoff) = 0;
  // True once a worker runs the call's job.
  virtual bool Running() = 0;
  // Ends the call with `status` (its job, if any, is detached).
  virtual void Abort(const grpc::Status& status) = 0;
  // Ends the call as refused: counted in the metrics, logged, then as Abort(refused.status).
  virtual void Refuse(const Refused& refused) = 0;
};

class Admission {
 public:
  using Clock = std::chrono::steady_clock;
  // `metrics` (which must outlive this) is the service's: a call counts its refusal there
  // (AdmittedCall::Refuse).
  explicit Admission(const ServerOptions& options, ServiceMetrics& metrics = NoMetrics());
  ~Admission();  // stops the reaper
  Admission(const Admission&) = delete;
  Admission& operator=(const Admission&) = delete;

  // Registers a new call; nullopt when it may go on, else its refusal (draining: UNAVAILABLE;
  // more than --max-concurrent-streams open: RESOURCE_EXHAUSTED). Every call that was opened is
  // closed, whatever Open answered.
  std::optional<Refused> Open(AdmittedCall* call);
  void Close(AdmittedCall* call);

  // nullopt, or UNAVAILABLE once shutdown has begun: for a job about to be queued.
  std::optional<Refused> CheckNotDraining() const;

  MemoryBudget& budget() { return budget_; }
  const MemoryBudget& budget() const { return budget_; }

  ServiceMetrics& metrics() { return metrics_; }

  // The job queue is full: RESOURCE_EXHAUSTED.
  Refused QueueFull() const;
  // nullopt, or RESOURCE_EXHAUSTED (kJobTooLarge) naming both figures when a job of `params` on
  // `vertices` and `faces` (the upload's head: DracoDeclaredCounts) needs more memory by its
  // estimate (EstimateJobBytes, job_memory.h) than --max-job-bytes allows; none without it.
  std::optional<Refused> CheckJobMemory(int64_t vertices, int64_t faces, const JobParams& params) const;
  // A mesh chunk of `bytes` above kMaxChunkBytes: RESOURCE_EXHAUSTED, as gRPC's own answer to a
  // message above its receive limit.
  Refused ChunkTooLarge(int64_t bytes) const;

  // Shutdown, in order: refuse new calls and end every call whose job has not started; wait
  // until `deadline` for the rest, returning as soon as none is left; end what is left with
  // UNAVAILABLE. Returns how many calls the deadline cut.
  int Drain(Clock::time_point deadline);

 private:
  void Reap();
  void StopReaper();

  const ServerOptions options_;
  ServiceMetrics& metrics_;
  MemoryBudget budget_;
  std::atomic<bool> draining_{false};
  std::mutex mu_;  // guards calls_ and reaper_stop_
  std::set<AdmittedCall*> calls_;
  std::condition_variable reaper_cv_;
  bool reaper_stop_ = false;
  std::thread reaper_;
};

}  // namespace meshsmooth::server
