// The meshsmooth.v1.MeshSmoother service on gRPC's callback API: a thin layer that moves bytes
// and maps statuses; all geometry happens in SmoothJob on the worker pool.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

#include "meshsmooth/v1/smoothing.grpc.pb.h"
#include "server/admission.h"
#include "server/job_runner.h"
#include "server/job_store.h"
#include "server/metrics.h"
#include "server/options.h"
#include "server/worker_pool.h"

namespace meshsmooth::server {

// The id the service gives the `n`th job (from 1) without one of its own: "TAG-N", TAG the
// service's start in seconds since the epoch, in hex.
std::string JobIdOf(uint64_t start_tag, uint64_t n);

class MeshSmootherService final : public v1::MeshSmoother::CallbackService {
 public:
  // Its events go to `metrics`, which must outlive it. With a `store` it serves the job methods
  // (Submit .. FetchResult) and runs the store's jobs on its workers; without, they answer
  // UNIMPLEMENTED.
  explicit MeshSmootherService(const ServerOptions& options, ServiceMetrics& metrics = NoMetrics(),
                               std::unique_ptr<JobStore> store = nullptr);
  ~MeshSmootherService() override;

  grpc::ServerBidiReactor<v1::SmoothRequest, v1::SmoothResponse>* Smooth(grpc::CallbackServerContext* context) override;
  grpc::ServerUnaryReactor* ListFlows(grpc::CallbackServerContext* context, const v1::ListFlowsRequest* request,
                                      v1::ListFlowsResponse* response) override;

  // The job methods (server/job_calls.h).
  grpc::ServerReadReactor<v1::SubmitRequest>* Submit(grpc::CallbackServerContext* context,
                                                     v1::SubmitResponse* response) override;
  grpc::ServerUnaryReactor* QueryUpload(grpc::CallbackServerContext* context, const v1::QueryUploadRequest* request,
                                        v1::SubmitResponse* response) override;
  grpc::ServerUnaryReactor* GetJob(grpc::CallbackServerContext* context, const v1::GetJobRequest* request,
                                   v1::Job* response) override;
  grpc::ServerUnaryReactor* ListJobs(grpc::CallbackServerContext* context, const v1::ListJobsRequest* request,
                                     v1::ListJobsResponse* response) override;
  grpc::ServerWriteReactor<v1::JobEvent>* WatchJob(grpc::CallbackServerContext* context,
                                                   const v1::WatchJobRequest* request) override;
  grpc::ServerUnaryReactor* CancelJob(grpc::CallbackServerContext* context, const v1::CancelJobRequest* request,
                                      v1::Job* response) override;
  grpc::ServerUnaryReactor* DeleteJob(grpc::CallbackServerContext* context, const v1::DeleteJobRequest* request,
                                      v1::DeleteJobResponse* response) override;
  grpc::ServerWriteReactor<v1::FetchResultResponse>* FetchResult(grpc::CallbackServerContext* context,
                                                                 const v1::FetchResultRequest* request) override;

  // Shutdown, in order: refuse new calls, end uploads and queued jobs with UNAVAILABLE, wait
  // until `deadline` for running jobs (no longer than the last of them takes), then end the
  // rest with UNAVAILABLE and stop the workers. Returns how many jobs the deadline cut.
  int DrainAndStop(std::chrono::steady_clock::time_point deadline);

  // The state a metrics scrape reads.
  ServiceGauges Gauges();

  // Jobs waiting for a worker now (for tests).
  int queued_jobs() { return pool_.queued(); }
  // Bytes held against --max-buffered-bytes now: uploads in flight and queued jobs (for tests).
  int64_t buffered_bytes() const { return admission_.budget().held(); }

 private:
  // OK, or UNAUTHENTICATED when the server has a token and the call's metadata does not carry it.
  grpc::Status Authenticate(const grpc::CallbackServerContext* context) const;
  std::string NewJobId();
  // A unary call's reactor finished with `status`, or with the authentication's refusal.
  template <typename Fn>
  grpc::ServerUnaryReactor* Unary(grpc::CallbackServerContext* context, Fn&& fn);

  const ServerOptions options_;
  Admission admission_;
  WorkerPool pool_;
  std::atomic<uint64_t> next_job_{1};
  const uint64_t start_tag_;
  std::unique_ptr<JobStore> store_;    // null without --job-store
  std::unique_ptr<JobRunner> runner_;  // after pool_ and store_: goes before them
};

}  // namespace meshsmooth::server
