// The job methods of meshsmooth.v1.MeshSmoother (Submit .. FetchResult) over the job store and
// its runner: gRPC in, store calls, gRPC out. Every one answers UNIMPLEMENTED when `runner` is
// null (a server without --job-store), and `authenticated` when it is not OK.
#pragma once

#include "grpcpp/grpcpp.h"
#include "meshsmooth/v1/smoothing.grpc.pb.h"
#include "server/job_runner.h"
#include "server/options.h"

namespace meshsmooth::server {

grpc::ServerReadReactor<v1::SubmitRequest>* NewSubmitReactor(const grpc::Status& authenticated, JobRunner* runner,
                                                             const ServerOptions& options,
                                                             v1::SubmitResponse* response);
grpc::ServerWriteReactor<v1::JobEvent>* NewWatchReactor(const grpc::Status& authenticated, JobRunner* runner,
                                                        const v1::WatchJobRequest& request);
grpc::ServerWriteReactor<v1::FetchResultResponse>* NewFetchReactor(const grpc::Status& authenticated, JobRunner* runner,
                                                                   const v1::FetchResultRequest& request);

grpc::Status QueryUpload(JobRunner* runner, const v1::QueryUploadRequest& request, v1::SubmitResponse* response);
grpc::Status GetJob(JobRunner* runner, const v1::GetJobRequest& request, v1::Job* response);
grpc::Status ListJobs(JobRunner* runner, const v1::ListJobsRequest& request, v1::ListJobsResponse* response);
grpc::Status CancelJob(JobRunner* runner, const v1::CancelJobRequest& request, v1::Job* response);
grpc::Status DeleteJob(JobRunner* runner, const v1::DeleteJobRequest& request);

}  // namespace meshsmooth::server
