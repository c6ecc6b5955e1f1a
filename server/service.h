// The meshsmooth.v1.MeshSmoother service on gRPC's callback API: a thin layer that moves bytes
// and maps statuses; all geometry happens in SmoothJob on the worker pool.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <set>

#include "meshsmooth/v1/smoothing.grpc.pb.h"
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

  // Shutdown, in order: refuse new jobs, wait up to `grace` for running ones, then end the rest
  // with UNAVAILABLE and stop the workers.
  void DrainAndStop(double grace_seconds);

  // Jobs waiting for a worker now (for tests).
  int queued_jobs() { return pool_.queued(); }

 private:
  friend class SmoothReactor;
  bool Authorized(const grpc::CallbackServerContext* context) const;
  void Register(SmoothReactor* r);
  void Unregister(SmoothReactor* r);

  const ServerOptions options_;
  WorkerPool pool_;
  std::atomic<int> active_{0};
  std::atomic<uint64_t> next_job_{1};
  std::atomic<bool> draining_{false};
  const uint64_t start_tag_;
  std::mutex mu_;  // guards reactors_
  std::set<SmoothReactor*> reactors_;
};

}  // namespace meshsmooth::server
