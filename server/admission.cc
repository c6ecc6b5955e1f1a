#include "server/admission.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "server/job_memory.h"

namespace meshsmooth::server {

bool MemoryBudget::TryTake(int64_t bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  if (bytes > limit_ - held_) return false;
  held_ += bytes;
  return true;
}

void MemoryBudget::Give(int64_t bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  held_ -= bytes;
}

int64_t MemoryBudget::held() const {
  std::lock_guard<std::mutex> lock(mu_);
  return held_;
}

BudgetHold::BudgetHold(BudgetHold&& other) noexcept
    : budget_(std::exchange(other.budget_, nullptr)), bytes_(std::exchange(other.bytes_, 0)) {}

BudgetHold& BudgetHold::operator=(BudgetHold&& other) noexcept {
  if (this != &other) {
    Release();
    budget_ = std::exchange(other.budget_, nullptr);
    bytes_ = std::exchange(other.bytes_, 0);
  }
  return *this;
}

bool BudgetHold::TryGrow(int64_t bytes) {
  if (budget_ == nullptr || !budget_->TryTake(bytes)) return false;
  bytes_ += bytes;
  return true;
}

void BudgetHold::Release() {
  if (budget_ != nullptr && bytes_ > 0) budget_->Give(bytes_);
  bytes_ = 0;
}

std::optional<Refused> UploadBuffer::Append(std::string_view chunk) {
  const size_t size = bytes_.size() + chunk.size();
  if (static_cast<int64_t>(size) > max_bytes_) {
    return Refused{Refusal::kUploadTooLarge, grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                                                          absl::StrCat("the upload exceeds this server's limit of ",
                                                                       max_bytes_, " bytes (--max-upload-bytes)"))};
  }
  const size_t capacity = static_cast<size_t>(hold_.bytes());
  if (size > capacity) {
    const size_t grown = std::min(std::max(size, 2 * capacity), static_cast<size_t>(max_bytes_));
    if (!hold_.TryGrow(static_cast<int64_t>(grown - capacity))) {
      return Refused{Refusal::kMemoryBudget,
                     grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                                  absl::StrCat("this server's memory budget for uploads and queued jobs is full (",
                                               budget_->held(), " of ", budget_->limit(),
                                               " bytes held; --max-buffered-bytes); retry later"))};
    }
    std::string bigger;
    bigger.reserve(grown);  // from empty: exactly `grown` (growing in place could double it)
    bigger.append(bytes_);
    bytes_.swap(bigger);
  }
  bytes_.append(chunk);
  metrics_.UploadReceived(static_cast<int64_t>(chunk.size()));
  return std::nullopt;
}

bool IsTransient(Refusal reason) {
  switch (reason) {
    case Refusal::kQueueFull:
    case Refusal::kQueueWait:
    case Refusal::kMemoryBudget:
    case Refusal::kTooManyCalls:
      return true;
    default:
      return false;
  }
}

int64_t DefaultBufferedBytes(const std::string& meminfo_path) {
  const std::optional<int64_t> total = MeminfoBytes("MemTotal", meminfo_path);
  if (total.has_value() && *total > 0) return *total / 4;
  return int64_t{4} << 30;
}

}  // namespace meshsmooth::server

namespace meshsmooth::server {
namespace {

// `seconds` as a clock duration; 0 for "never" (<= 0), capped where a clock would overflow.
Admission::Clock::duration Limit(double seconds) {
  if (!(seconds > 0.0)) return Admission::Clock::duration::zero();
  return std::chrono::duration_cast<Admission::Clock::duration>(std::chrono::duration<double>(std::min(seconds, 1e9)));
}

// For a job that has not started when the server begins to shut down: safe to send again.
Refused ShuttingDown() {
  return {Refusal::kShuttingDown,
          grpc::Status(grpc::StatusCode::UNAVAILABLE,
                       "meshsmoothd is shutting down; the job did not start: send it to another replica")};
}

}  // namespace

Admission::Admission(const ServerOptions& options, ServiceMetrics& metrics)
    : options_(options),
      metrics_(metrics),
      budget_(options.max_buffered_bytes > 0 ? options.max_buffered_bytes : DefaultBufferedBytes()) {
  if (options.upload_idle_seconds > 0.0 || options.max_queue_wait_seconds > 0.0) {
    reaper_ = std::thread([this] { Reap(); });
  }
}

Admission::~Admission() { StopReaper(); }

std::optional<Refused> Admission::Open(AdmittedCall* call) {
  size_t open = 0;
  {
    std::lock_guard<std::mutex> lock(mu_);
    calls_.insert(call);
    open = calls_.size();
  }
  if (draining_.load()) return ShuttingDown();
  if (static_cast<int64_t>(open) > options_.max_concurrent_streams) {
    return Refused{Refusal::kTooManyCalls,
                   grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                                absl::StrCat("too many concurrent Smooth calls (limit ",
                                             options_.max_concurrent_streams, "); retry later"))};
  }
  return std::nullopt;
}

void Admission::Close(AdmittedCall* call) {
  std::lock_guard<std::mutex> lock(mu_);
  calls_.erase(call);
}

std::optional<Refused> Admission::CheckNotDraining() const {
  if (!draining_.load()) return std::nullopt;
  return ShuttingDown();
}

Refused Admission::QueueFull() const {
  return {Refusal::kQueueFull,
          grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                       absl::StrCat("the job queue is full (", options_.queue_depth, " jobs waiting); retry later"))};
}

std::optional<Refused> Admission::CheckJobMemory(int64_t vertices, int64_t faces, const JobParams& params) const {
  if (options_.max_job_bytes <= 0) return std::nullopt;
  const int64_t needed = EstimateJobBytes(vertices, faces, params);
  if (needed <= options_.max_job_bytes) return std::nullopt;
  return Refused{Refusal::kJobTooLarge,
                 grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                              absl::StrCat("the job needs about ", FormatBytes(needed), " of memory, estimated for ",
                                           DescribeJobSize(vertices, faces, params), ", above this server's limit of ",
                                           FormatBytes(options_.max_job_bytes),
                                           " a job (--max-job-bytes); send a smaller mesh, or run it locally "
                                           "(meshsmooth without --server)"))};
}

Refused Admission::ChunkTooLarge(int64_t bytes) const {
  return {Refusal::kChunkTooLarge,
          grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                       absl::StrCat("a mesh chunk of ", bytes, " bytes is above this server's limit of ",
                                    kMaxChunkBytes, " bytes per chunk"))};
}

int Admission::Drain(Clock::time_point deadline) {
  draining_.store(true);
  // Uploads and queued jobs end at once: their clients can send them to another replica now
  // rather than after the grace.
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (AdmittedCall* c : calls_) {
      if (!c->Running()) c->Refuse(ShuttingDown());
    }
  }
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (calls_.empty()) break;
    }
    if (Clock::now() >= deadline) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const grpc::Status after_grace(
      grpc::StatusCode::UNAVAILABLE,
      absl::StrFormat("meshsmoothd shut down; the job was cancelled after the %g s grace period",
                      options_.grace_seconds));
  std::lock_guard<std::mutex> lock(mu_);
  for (AdmittedCall* c : calls_) c->Abort(after_grace);
  return static_cast<int>(calls_.size());
}

void Admission::Reap() {
  const Clock::duration idle = Limit(options_.upload_idle_seconds);
  const Clock::duration queue_wait = Limit(options_.max_queue_wait_seconds);
  // A call ends between its limit and 1.25 x its limit after it began to wait.
  Clock::duration shortest = std::chrono::hours(1);
  if (idle > Clock::duration::zero()) shortest = std::min(shortest, idle);
  if (queue_wait > Clock::duration::zero()) shortest = std::min(shortest, queue_wait);
  const auto period = std::clamp<Clock::duration>(shortest / 4, std::chrono::milliseconds(10), std::chrono::seconds(1));
  const Refused idle_refusal{
      Refusal::kUploadIdle,
      grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED,
                   absl::StrFormat("no message for %g s: this server ends uploads that stop sending "
                                   "(--upload-idle-seconds); send the spec, the whole mesh, then half-close",
                                   options_.upload_idle_seconds))};
  const Refused wait_refusal{
      Refusal::kQueueWait,
      grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                   absl::StrFormat("the job waited %g s for a worker without getting one (--max-queue-wait); this "
                                   "replica is saturated: retry later or on another replica",
                                   options_.max_queue_wait_seconds))};
  std::unique_lock<std::mutex> lock(mu_);
  while (!reaper_stop_) {
    reaper_cv_.wait_for(lock, period);
    const Clock::time_point now = Clock::now();
    for (AdmittedCall* c : calls_) {  // a call is deleted only after Close
      if (idle > Clock::duration::zero() && c->IdleSince(now - idle)) {
        c->Refuse(idle_refusal);
      } else if (queue_wait > Clock::duration::zero() && c->QueuedSince(now - queue_wait)) {
        c->Refuse(wait_refusal);
      }
    }
  }
}

void Admission::StopReaper() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    reaper_stop_ = true;
  }
  reaper_cv_.notify_all();
  if (reaper_.joinable()) reaper_.join();
}

}  // namespace meshsmooth::server
