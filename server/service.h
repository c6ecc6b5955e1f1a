// The meshsmooth.v1.MeshSmoother service on gRPC's callback API: a thin layer that moves bytes
// and maps statuses; all geometry happens in SmoothJob on the worker pool.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include "meshsmooth/v1/smoothing.grpc.pb.h"
#include "server/admission.h"
#include "server/options.h"
#include "server/worker_pool.h"

namespace meshsmooth::server {

class SmoothReactor;

class MeshSmootherService final : public v1::MeshSmoother::CallbackService {
 public:
  explicit MeshSmootherService(const ServerOptions& options);
  ~MeshSmootherService() override;

  grpc::ServerBidiReactor<v1::SmoothRequest, v1::SmoothResponse>* Smooth(
      grpc::CallbackServerContext* context) override;
  grpc::ServerUnaryReactor* ListFlows(grpc::CallbackServerContext* context, const v1::ListFlowsRequest* request,
                                     v1::ListFlowsResponse* response) override;

  // Shutdown, in order: refuse new calls, end uploads and queued jobs with UNAVAILABLE, wait
  // until `deadline` for running jobs, then end the rest with UNAVAILABLE and stop the workers.
  void DrainAndStop(std::chrono::steady_clock::time_point deadline);

  // Jobs waiting for a worker now (for tests).
  int queued_jobs() { return pool_.queued(); }
  // Bytes held against --max-buffered-bytes now: uploads in flight and queued jobs (for tests).
  int64_t buffered_bytes() const { return budget_.held(); }

 private:
  friend class SmoothReactor;
  bool Authorized(const grpc::CallbackServerContext* context) const;
  void Register(SmoothReactor* r);
  void Unregister(SmoothReactor* r);
  // The reaper thread, until StopReaper(): ends the uploads idle for --upload-idle-seconds and
  // the jobs queued for longer than --max-queue-wait.
  void Reap();
  void StopReaper();

  const ServerOptions options_;
  MemoryBudget budget_;
  WorkerPool pool_;
  std::atomic<int> active_{0};
  std::atomic<uint64_t> next_job_{1};
  std::atomic<bool> draining_{false};
  const uint64_t start_tag_;
  std::mutex mu_;  // guards reactors_ and reaper_stop_
  std::set<SmoothReactor*> reactors_;
  std::condition_variable reaper_cv_;
  bool reaper_stop_ = false;
  std::thread reaper_;
};

}  // namespace meshsmooth::server
