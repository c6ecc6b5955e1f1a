// Runs the job store's jobs on the service's worker pool: claims the oldest QUEUED job (or one
// whose lease ran out) whenever fewer of the store's jobs than workers are on the pool, runs it
// as a SmoothJob whose events go to the store (state, progress, result, error), renews the
// leases of its jobs at each tick, and tells the watchers of a job (WatchJob) each change — on a
// store other replicas share, by reading the watched jobs' rows at each tick too. Also forgets
// ended jobs past --job-retention, and sends a job's completion callback (JobSpec.callback_url)
// when it ends, with --callback-secret-file. Jobs from Smooth calls share the pool: at most `workers`
// stored jobs sit on it at once, so they never fill its queue.
#pragma once

#include <atomic>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "server/job_store.h"
#include "server/metrics.h"
#include "server/options.h"
#include "server/worker_pool.h"

namespace meshsmooth::server {

class CallbackSender;
class SmoothJob;

// Told each change of a watched job (WatchJob's reactor); called on whichever thread made it,
// with the runner's watcher lock held: it must not call back into the runner.
class JobWatcher {
 public:
  virtual ~JobWatcher() = default;
  virtual void OnJobChanged(const v1::Job& job) = 0;
};

// Microseconds since the Unix epoch, the store's clock.
int64_t NowMicros();

class JobRunner {
 public:
  // `store`, `pool` and `metrics` must outlive the runner. Starts its scheduling thread.
  JobRunner(JobStore& store, WorkerPool& pool, const ServerOptions& options, ServiceMetrics& metrics);
  ~JobRunner();  // Stop()
  JobRunner(const JobRunner&) = delete;
  JobRunner& operator=(const JobRunner&) = delete;

  JobStore& store() { return store_; }
  ServiceMetrics& metrics() { return metrics_; }
  // A job was queued: schedule now rather than at the next tick.
  void Wake();
  // CancelJob: the store's state first, then a running job stopped within one iteration.
  absl::StatusOr<v1::Job> Cancel(const std::string& job_id);
  // DeleteJob: the store's Delete, logged.
  absl::Status Delete(const std::string& job_id);
  // The job's own change of state has just ended it (SUCCEEDED, FAILED or CANCELLED, once per
  // job): its callback, when its spec names one.
  void Ended(const std::string& job_id);
  // Each change of `job_id` goes to `watcher` until Unwatch.
  void Watch(const std::string& job_id, JobWatcher* watcher);
  void Unwatch(const std::string& job_id, JobWatcher* watcher);
  // Tells the watchers of `job_id` its state now.
  void Notify(const std::string& job_id);

  // Stops scheduling and stops the running jobs within one iteration. They go back to QUEUED in
  // the store, so that the next start (or another replica) runs them again from their input.
  // Callbacks not yet delivered are dropped.
  void Stop();

  int active() {
    std::lock_guard<std::mutex> lock(mu_);
    return static_cast<int>(active_.size());
  }
  // Jobs this runner claimed after the lease of another run had run out.
  int64_t lease_takeovers() const { return lease_takeovers_.load(); }

 private:
  void Loop();
  // Claims one job and puts it on the pool; false when there is none or no room.
  bool Dispatch();
  // Extends the leases of this runner's jobs; a job whose lease is lost stops.
  void RenewLeases();
  // Tells each watched job's watchers its row now (changes other replicas made).
  void NotifyWatched();
  // On a worker: the claimed job's run, to the store.
  void Run(ClaimedJob claimed);

  JobStore& store_;
  WorkerPool& pool_;
  const ServerOptions options_;
  ServiceMetrics& metrics_;
  std::mutex mu_;  // guards everything below but the watchers
  std::condition_variable cv_;
  bool stopping_ = false;
  bool woken_ = false;
  // The store's jobs on the pool, queued there or running (then with their SmoothJob).
  std::map<std::string, std::shared_ptr<SmoothJob>> active_;
  std::atomic<int64_t> lease_takeovers_{0};
  std::mutex cancel_mu_;                       // one CancelJob at a time: its state before and after are its own
  std::unique_ptr<CallbackSender> callbacks_;  // null without --callback-secret-file
  std::mutex watch_mu_;
  std::multimap<std::string, JobWatcher*> watchers_;
  std::thread thread_;
};

}  // namespace meshsmooth::server
