// One Smooth call on gRPC's callback API (smooth_reactor.cc): reads the spec and the upload,
// hands the job to the worker pool, then writes the job's events back with one write in flight
// (accepted, the newest progress, result chunks, summary) and finishes exactly once. It is given
// what it needs: the admission that registers it and owns the server's limits, the pool, the
// options, and a source of job ids.
#pragma once

#include <functional>
#include <string>

#include "meshsmooth/v1/smoothing.grpc.pb.h"
#include "server/admission.h"
#include "server/options.h"
#include "server/worker_pool.h"

namespace meshsmooth::server {

// A new Smooth call's reactor on `context` (the client's address, for the log; the trailing
// metadata of a RESOURCE_EXHAUSTED); it deletes itself when gRPC is done with the call.
// `authenticated`: OK, or the status the call ends with at once (a refusal, logged and
// counted). `new_job_id` names a job whose spec brings no id. The references must outlive every
// call (the service owns them); events go to admission.metrics(), refusals to the log too.
grpc::ServerBidiReactor<v1::SmoothRequest, v1::SmoothResponse>* NewSmoothReactor(
    const grpc::Status& authenticated, grpc::CallbackServerContext* context, Admission& admission, WorkerPool& pool,
    const ServerOptions& options, std::function<std::string()> new_job_id);

}  // namespace meshsmooth::server
