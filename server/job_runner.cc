#include "server/job_runner.h"

#include <algorithm>
#include <chrono>
#include <vector>

#include "absl/strings/str_cat.h"
#include "server/callbacks.h"
#include "server/convert.h"
#include "server/log.h"
#include "server/smooth_job.h"

namespace meshsmooth::server {
namespace {

// How often the scheduler looks for work without being woken, and forgets expired jobs.
constexpr auto kTick = std::chrono::milliseconds(500);

// A stored job's events, into the store; each change then goes to the job's watchers.
class StoreSink final : public JobSink {
 public:
  StoreSink(std::string job_id, JobRunner& runner) : job_id_(std::move(job_id)), runner_(runner) {}
  void OnAccepted(const v1::Accepted&) override {}
  void OnProgress(const v1::Progress& progress) override {
    runner_.store().SetProgress(job_id_, progress);  // the job throttles it to ~10/s
    runner_.Notify(job_id_);
  }
  void OnResult(std::string draco_bytes, const v1::Summary& summary) override {
    const bool ended = runner_.store().Succeed(job_id_, draco_bytes, summary, NowMicros());
    runner_.Notify(job_id_);
    if (ended) runner_.Ended(job_id_);
  }
  void OnError(const absl::Status& status) override {
    const bool ended = runner_.store().Fail(job_id_, status, NowMicros());
    runner_.Notify(job_id_);
    if (ended) runner_.Ended(job_id_);
  }

 private:
  const std::string job_id_;
  JobRunner& runner_;
};

}  // namespace

int64_t NowMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

JobRunner::JobRunner(JobStore& store, WorkerPool& pool, const ServerOptions& options, ServiceMetrics& metrics)
    : store_(store),
      pool_(pool),
      options_(options),
      metrics_(metrics),
      callbacks_(options.callback_secret.empty()
                     ? nullptr
                     : std::make_unique<CallbackSender>(options.callback_secret, options.log_format)),
      thread_([this] { Loop(); }) {}

JobRunner::~JobRunner() { Stop(); }

void JobRunner::Wake() {
  std::lock_guard<std::mutex> lock(mu_);
  woken_ = true;
  cv_.notify_all();
}

void JobRunner::Stop() {
  std::map<std::string, std::shared_ptr<SmoothJob>> running;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (stopping_) return;
    stopping_ = true;
    running = active_;
    cv_.notify_all();
  }
  for (auto& [id, job] : running) {
    if (job) job->Detach();
  }
  if (thread_.joinable()) thread_.join();
  // Their runs were cut: back to the queue now, for the next start or another replica, rather
  // than when their leases run out.
  for (auto& [id, job] : running) store_.Release(id, /*undo_attempt=*/job == nullptr);
  if (callbacks_) callbacks_->Stop();
}

void JobRunner::Loop() {
  std::unique_lock<std::mutex> lock(mu_);
  while (!stopping_) {
    lock.unlock();
    if (options_.job_retention_seconds > 0) {
      store_.ExpireEndedBefore(NowMicros() - static_cast<int64_t>(options_.job_retention_seconds * 1e6));
    }
    RenewLeases();
    while (Dispatch()) {
    }
    if (store_.shared()) NotifyWatched();
    lock.lock();
    cv_.wait_for(lock, kTick, [this] { return stopping_ || woken_; });
    woken_ = false;
  }
}

void JobRunner::RenewLeases() {
  std::map<std::string, std::shared_ptr<SmoothJob>> active;
  {
    std::lock_guard<std::mutex> lock(mu_);
    active = active_;
  }
  for (const auto& [id, job] : active) {
    // Cancelled or taken over elsewhere: stop within one iteration; its late events go nowhere.
    if (!store_.RenewLease(id, NowMicros()) && job) job->Detach();
  }
}

void JobRunner::NotifyWatched() {
  std::vector<std::string> ids;
  {
    std::lock_guard<std::mutex> lock(watch_mu_);
    for (auto it = watchers_.begin(); it != watchers_.end(); it = watchers_.upper_bound(it->first)) {
      ids.push_back(it->first);
    }
  }
  for (const std::string& id : ids) Notify(id);
}

bool JobRunner::Dispatch() {
  std::vector<std::string> skip;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (stopping_ || static_cast<int>(active_.size()) >= pool_.workers()) return false;
    for (const auto& [id, job] : active_) skip.push_back(id);
  }
  std::optional<ClaimedJob> claimed = store_.Claim(skip, NowMicros());
  if (!claimed.has_value()) return false;
  const std::string id = claimed->job_id;
  if (claimed->takeover) {
    lease_takeovers_.fetch_add(1);
    LogEvent(options_.log_format, "warning", "lease_takeover",
             absl::StrCat("job=", id, " taken over: the lease of the replica that ran it ran out"),
             [&](JsonLine& l) { l.Str("job_id", id); });
  }
  {
    std::lock_guard<std::mutex> lock(mu_);
    active_.emplace(id, nullptr);
  }
  Notify(id);
  auto task = std::make_shared<ClaimedJob>(*std::move(claimed));
  if (!pool_.TrySubmit([this, task] { Run(std::move(*task)); })) {  // the queue is full of Smooth calls
    store_.Release(id, /*undo_attempt=*/true);
    std::lock_guard<std::mutex> lock(mu_);
    active_.erase(id);
    return false;
  }
  return true;
}

void JobRunner::Run(ClaimedJob claimed) {
  const std::string job_id = claimed.job_id;
  const auto done = [&] {
    std::lock_guard<std::mutex> lock(mu_);
    active_.erase(job_id);
    woken_ = true;
    cv_.notify_all();
  };
  bool stopping;
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping = stopping_;
  }
  if (stopping) {  // never started: back to the queue for the next start or another replica
    store_.Release(job_id, /*undo_attempt=*/true);
    return done();
  }
  StoreSink sink(job_id, *this);
  v1::JobSpec spec = claimed.input.spec;
  spec.clear_job_id();
  absl::StatusOr<JobParams> params = FromProto(spec, options_.max_iterations);
  if (!params.ok()) {  // checked at Submit; a server with a lower --max-iterations since then
    sink.OnError(params.status());
    return done();
  }
  params->job_id = job_id;
  auto job = std::make_shared<SmoothJob>(job_id, *std::move(params), std::move(claimed.input.upload), BudgetHold(),
                                         Clock::now(), options_, &sink, "job-store", metrics_);
  {
    std::lock_guard<std::mutex> lock(mu_);
    active_[job_id] = job;
    if (stopping_) job->Detach();
  }
  // A cancel (or a takeover) between the claim and here found no SmoothJob to stop: ask the store.
  if (!store_.RenewLease(job_id, NowMicros())) job->Detach();
  job->Run();
  job->Detach();  // the sink goes with this frame
  done();
}

absl::StatusOr<v1::Job> JobRunner::Cancel(const std::string& job_id) {
  std::unique_lock<std::mutex> one_at_a_time(cancel_mu_);
  const absl::StatusOr<v1::Job> before = store_.Get(job_id);
  absl::StatusOr<v1::Job> job = store_.Cancel(job_id, NowMicros());
  if (!job.ok()) return job;
  // This call ended it when it was QUEUED or RUNNING before and is CANCELLED now (a run that
  // succeeded or failed in between keeps its own end).
  const bool ended_here = before.ok() &&
                          (before->state() == v1::JOB_STATE_QUEUED || before->state() == v1::JOB_STATE_RUNNING) &&
                          job->state() == v1::JOB_STATE_CANCELLED;
  one_at_a_time.unlock();
  if (ended_here) {
    LogJobEvent(options_.log_format, "info", "job_cancelled", job_id,
                absl::StrCat("cancelled (was ", JobStateName(before->state()), ")"));
  }
  std::shared_ptr<SmoothJob> running;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (auto it = active_.find(job_id); it != active_.end()) running = it->second;
  }
  if (running) running->Detach();  // stops within one iteration; its late events go nowhere
  Notify(job_id);
  if (ended_here) Ended(job_id);
  return job;
}

absl::Status JobRunner::Delete(const std::string& job_id) {
  absl::Status s = store_.Delete(job_id);
  if (s.ok()) LogJobEvent(options_.log_format, "info", "job_deleted", job_id, "deleted with its upload and result");
  return s;
}

void JobRunner::Ended(const std::string& job_id) {
  absl::StatusOr<v1::Job> job = store_.Get(job_id);
  if (!job.ok() || job->spec().callback_url().empty()) return;
  if (callbacks_ == nullptr) {  // queued by a server that had a secret
    LogJobEvent(options_.log_format, "warning", "callback", job_id,
                "callback not sent: this server has no --callback-secret-file", [](JsonLine& l) {
                  l.Int("attempt", 0).Int("http_status", 0).Str("outcome", "dropped").Str("error", "no secret");
                });
    return;
  }
  callbacks_->Send(*job);
}

void JobRunner::Watch(const std::string& job_id, JobWatcher* watcher) {
  std::lock_guard<std::mutex> lock(watch_mu_);
  watchers_.emplace(job_id, watcher);
}

void JobRunner::Unwatch(const std::string& job_id, JobWatcher* watcher) {
  std::lock_guard<std::mutex> lock(watch_mu_);
  auto [begin, end] = watchers_.equal_range(job_id);
  for (auto it = begin; it != end; ++it) {
    if (it->second == watcher) {
      watchers_.erase(it);
      return;
    }
  }
}

void JobRunner::Notify(const std::string& job_id) {
  {
    std::lock_guard<std::mutex> lock(watch_mu_);
    if (watchers_.count(job_id) == 0) return;
  }
  absl::StatusOr<v1::Job> job = store_.Get(job_id);
  if (!job.ok()) return;
  job->clear_spec();
  std::lock_guard<std::mutex> lock(watch_mu_);
  auto [begin, end] = watchers_.equal_range(job_id);
  for (auto it = begin; it != end; ++it) it->second->OnJobChanged(*job);
}

}  // namespace meshsmooth::server
