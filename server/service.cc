#include "server/service.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/flows/catalogue.h"
#include "core/job/enhance.h"
#include "server/convert.h"
#include "server/job_calls.h"
#include "server/log.h"
#include "server/smooth_job.h"
#include "server/smooth_reactor.h"

namespace meshsmooth::server {
namespace {

int HardwareThreads() { return std::max(1u, std::thread::hardware_concurrency()); }

}  // namespace

MeshSmootherService::MeshSmootherService(const ServerOptions& options, ServiceMetrics& metrics,
                                         std::unique_ptr<JobStore> store)
    : options_(options),
      admission_(options_, metrics),
      pool_(options.workers > 0 ? options.workers : HardwareThreads(), options.queue_depth),
      start_tag_(static_cast<uint64_t>(
          std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch())
              .count())),
      store_(std::move(store)) {
  if (store_) runner_ = std::make_unique<JobRunner>(*store_, pool_, options_, metrics);
}

MeshSmootherService::~MeshSmootherService() {
  if (runner_) runner_->Stop();  // first: the pool's Stop waits for its running tasks
  pool_.Stop();
}

grpc::Status MeshSmootherService::Authenticate(const grpc::CallbackServerContext* context) const {
  if (options_.auth_token.empty()) return grpc::Status::OK;
  const auto& md = context->client_metadata();
  const std::string expected = "Bearer " + options_.auth_token;
  for (auto it = md.find("authorization"); it != md.end() && it->first == "authorization"; ++it) {
    const std::string got(it->second.data(), it->second.size());
    if (got.size() != expected.size()) continue;
    unsigned char diff = 0;  // constant-time comparison
    for (size_t i = 0; i < got.size(); ++i) diff |= static_cast<unsigned char>(got[i] ^ expected[i]);
    if (diff == 0) return grpc::Status::OK;
  }
  return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                      "missing or wrong bearer token (send metadata 'authorization: Bearer <token>')");
}

std::string JobIdOf(uint64_t start_tag, uint64_t n) { return absl::StrFormat("%x-%d", start_tag, n); }

std::string MeshSmootherService::NewJobId() { return JobIdOf(start_tag_, next_job_.fetch_add(1)); }

grpc::ServerBidiReactor<v1::SmoothRequest, v1::SmoothResponse>* MeshSmootherService::Smooth(
    grpc::CallbackServerContext* context) {
  return NewSmoothReactor(Authenticate(context), context, admission_, pool_, options_, [this] { return NewJobId(); });
}

grpc::ServerUnaryReactor* MeshSmootherService::ListFlows(grpc::CallbackServerContext* context,
                                                         const v1::ListFlowsRequest*, v1::ListFlowsResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (grpc::Status s = Authenticate(context); !s.ok()) {
    admission_.metrics().Refused(Refusal::kUnauthenticated);
    if (options_.log_refusals) {
      LogRefusal(options_.log_format,
                 {"ListFlows", RefusalName(Refusal::kUnauthenticated), s, context->peer(), /*job_id=*/""});
    }
    reactor->Finish(s);
    return reactor;
  }
  for (const FlowInfo& f : DescribeFlows()) {
    v1::FlowInfo* out = response->add_flows();
    out->set_name(f.name);
    out->set_description(f.description);
    out->set_equations(f.equations);
    for (const ParameterInfo& p : f.parameters) ToProto(p, out->add_parameters());
    for (const std::string& c : f.constraints) out->add_constraints(c);
  }
  for (const ParameterInfo& p : CommonParameters(options_.max_iterations))
    ToProto(p, response->add_common_parameters());
  response->set_max_iterations(static_cast<uint32_t>(options_.max_iterations));
  for (const ParameterInfo& p : EnhanceParameters()) ToProto(p, response->add_enhance_parameters());
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

template <typename Fn>
grpc::ServerUnaryReactor* MeshSmootherService::Unary(grpc::CallbackServerContext* context, Fn&& fn) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  grpc::Status s = Authenticate(context);
  reactor->Finish(s.ok() ? fn() : s);
  return reactor;
}

grpc::ServerReadReactor<v1::SubmitRequest>* MeshSmootherService::Submit(grpc::CallbackServerContext* context,
                                                                        v1::SubmitResponse* response) {
  return NewSubmitReactor(Authenticate(context), runner_.get(), options_, response);
}

grpc::ServerUnaryReactor* MeshSmootherService::QueryUpload(grpc::CallbackServerContext* context,
                                                           const v1::QueryUploadRequest* request,
                                                           v1::SubmitResponse* response) {
  return Unary(context, [&] { return server::QueryUpload(runner_.get(), *request, response); });
}

grpc::ServerUnaryReactor* MeshSmootherService::GetJob(grpc::CallbackServerContext* context,
                                                      const v1::GetJobRequest* request, v1::Job* response) {
  return Unary(context, [&] { return server::GetJob(runner_.get(), *request, response); });
}

grpc::ServerUnaryReactor* MeshSmootherService::ListJobs(grpc::CallbackServerContext* context,
                                                        const v1::ListJobsRequest* request,
                                                        v1::ListJobsResponse* response) {
  return Unary(context, [&] { return server::ListJobs(runner_.get(), *request, response); });
}

grpc::ServerWriteReactor<v1::JobEvent>* MeshSmootherService::WatchJob(grpc::CallbackServerContext* context,
                                                                      const v1::WatchJobRequest* request) {
  return NewWatchReactor(Authenticate(context), runner_.get(), *request);
}

grpc::ServerUnaryReactor* MeshSmootherService::CancelJob(grpc::CallbackServerContext* context,
                                                         const v1::CancelJobRequest* request, v1::Job* response) {
  return Unary(context, [&] { return server::CancelJob(runner_.get(), *request, response); });
}

grpc::ServerUnaryReactor* MeshSmootherService::DeleteJob(grpc::CallbackServerContext* context,
                                                         const v1::DeleteJobRequest* request, v1::DeleteJobResponse*) {
  return Unary(context, [&] { return server::DeleteJob(runner_.get(), *request); });
}

grpc::ServerWriteReactor<v1::FetchResultResponse>* MeshSmootherService::FetchResult(
    grpc::CallbackServerContext* context, const v1::FetchResultRequest* request) {
  return NewFetchReactor(Authenticate(context), runner_.get(), *request);
}

int MeshSmootherService::DrainAndStop(Clock::time_point deadline) {
  const int cut = admission_.Drain(deadline);
  // The store's running jobs stop within one iteration and stay RUNNING in the store: the next
  // start runs them again from their input.
  if (runner_) runner_->Stop();
  pool_.Stop();  // a cancelled job stops within one iteration
  return cut;
}

ServiceGauges MeshSmootherService::Gauges() {
  ServiceGauges g;
  g.queued_jobs = pool_.queued();
  g.running_jobs = pool_.running();
  g.buffered_bytes = admission_.budget().held();
  g.buffered_bytes_limit = admission_.budget().limit();
  g.workers = pool_.workers();
  g.queue_capacity = options_.queue_depth;
  if (runner_) {
    const JobCounts counts = store_->Counts();
    g.job_store = true;
    g.stored_jobs = counts.by_state;
    if (counts.oldest_queued_us != 0) {
      g.oldest_queued_seconds = std::max(0.0, static_cast<double>(NowMicros() - counts.oldest_queued_us) / 1e6);
    }
    g.lease_takeovers = runner_->lease_takeovers();
  }
  return g;
}

}  // namespace meshsmooth::server
