#include "server/service.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/flows/catalogue.h"
#include "server/convert.h"
#include "server/smooth_job.h"

namespace meshsmooth::server {
namespace {

// absl and gRPC share status code numbers; long messages are cut so a status stays small.
grpc::Status ToGrpc(const absl::Status& s) {
  std::string message(s.message());
  if (message.size() > 2000) message = message.substr(0, 2000) + "...";
  return grpc::Status(static_cast<grpc::StatusCode>(s.code()), message);
}

int HardwareThreads() { return std::max(1u, std::thread::hardware_concurrency()); }

}  // namespace

// One Smooth call. Reads the spec and the chunks, hands the job to the pool, then writes the
// job's events back with one write in flight: accepted, the newest progress (older ones are
// dropped while a write is in flight), result chunks, summary, and Finish exactly once. Job events arrive on the worker
// thread; the job's own mutex is never taken while this reactor's mutex is held.
class SmoothReactor final : public grpc::ServerBidiReactor<v1::SmoothRequest, v1::SmoothResponse>,
                            public JobSink {
 public:
  SmoothReactor(MeshSmootherService* service, grpc::CallbackServerContext* context)
      : service_(service),
        received_(Clock::now()),
        upload_(&service->budget_, service->options_.max_upload_bytes),
        last_read_(received_) {
    service_->Register(this);
    if (!service_->Authorized(context)) {
      Abort(grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                         "missing or wrong bearer token (send metadata 'authorization: Bearer <token>')"));
      return;
    }
    if (service_->draining_.load()) {
      Abort(ShuttingDown());
      return;
    }
    if (service_->active_.load() > service_->options_.max_concurrent_streams) {
      Abort(grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                         absl::StrCat("too many concurrent Smooth calls (limit ",
                                      service_->options_.max_concurrent_streams, "); retry later")));
      return;
    }
    uploading_.store(true);
    StartRead(&request_);
  }

  // True while the call still reads its upload and its last message arrived before `cutoff`.
  bool IdleSince(Clock::time_point cutoff) const {
    return uploading_.load() && last_read_.load() < cutoff;
  }

  // For a job that has not started when the server begins to shut down: safe to send again.
  static grpc::Status ShuttingDown() {
    return grpc::Status(grpc::StatusCode::UNAVAILABLE,
                        "meshsmoothd is shutting down; the job did not start: send it to another replica");
  }

  // True while the call's job waits in the queue and was queued before `cutoff`.
  bool QueuedSince(Clock::time_point cutoff) {
    std::lock_guard<std::mutex> lock(mu_);
    return job_ != nullptr && !job_->started() && job_->submitted() < cutoff;
  }

  // True once a worker runs the call's job.
  bool Running() {
    std::lock_guard<std::mutex> lock(mu_);
    return job_ != nullptr && job_->started();
  }

  void OnReadDone(bool ok) override {
    last_read_.store(Clock::now());
    if (!ok) return OnHalfClose();
    const ServerOptions& options = service_->options_;
    switch (request_.kind_case()) {
      case v1::SmoothRequest::kSpec: {
        if (params_.has_value()) {
          return Abort(InvalidArgument("a second JobSpec arrived: send exactly one spec, first, then the mesh"));
        }
        absl::StatusOr<JobParams> params = FromProto(request_.spec(), options.max_iterations);
        if (!params.ok()) return Abort(ToGrpc(params.status()));
        params_ = std::move(params).value();
        break;
      }
      case v1::SmoothRequest::kMeshChunk: {
        if (!params_.has_value()) {
          return Abort(InvalidArgument("the first message must be a JobSpec (spec), not a mesh chunk"));
        }
        const std::string& chunk = request_.mesh_chunk();
        // Sizes beyond this server's limits are RESOURCE_EXHAUSTED, as gRPC's own answer to a
        // message above its receive limit (a chunk of more than kMaxReceiveMessageBytes).
        if (static_cast<int64_t>(chunk.size()) > kMaxChunkBytes) {
          return Abort(ResourceExhausted(absl::StrCat("a mesh chunk of ", chunk.size(),
                                                      " bytes is above this server's limit of ", kMaxChunkBytes,
                                                      " bytes per chunk")));
        }
        // The upload's own limit and the server's memory budget.
        if (absl::Status s = upload_.Append(chunk); !s.ok()) return Abort(ToGrpc(s));
        break;
      }
      default:
        return Abort(InvalidArgument("an empty SmoothRequest (neither spec nor mesh_chunk)"));
    }
    StartRead(&request_);
  }

  void OnWriteDone(bool ok) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      write_in_flight_ = false;
      if (!ok && !finish_status_) finish_status_ = grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
      if (!ok) cancelled_ = true;
    }
    Pump();
  }

  void OnCancel() override {
    std::shared_ptr<SmoothJob> job;
    {
      std::lock_guard<std::mutex> lock(mu_);
      cancelled_ = true;
      if (!finish_status_) finish_status_ = grpc::Status(grpc::StatusCode::CANCELLED, "the call was cancelled");
      job = job_;
    }
    if (job) job->Detach();  // stops the job within one iteration; frees its worker and memory
    Pump();
  }

  void OnDone() override {
    std::shared_ptr<SmoothJob> job;
    {
      std::lock_guard<std::mutex> lock(mu_);
      job = std::move(job_);
    }
    if (job) job->Detach();
    service_->Unregister(this);
    delete this;
  }

  // JobSink: called on the worker thread.
  void OnAccepted(const v1::Accepted& accepted) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      *pending_.emplace().mutable_accepted() = accepted;
    }
    Pump();
  }
  void OnProgress(const v1::Progress& progress) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!pending_progress_) pending_progress_.emplace();
      *pending_progress_->mutable_progress() = progress;
    }
    Pump();
  }
  void OnResult(std::string draco_bytes, const v1::Summary& summary) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      result_ = std::move(draco_bytes);
      summary_ = summary;
      have_result_ = true;
    }
    Pump();
  }
  void OnError(const absl::Status& status) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!finish_status_) finish_status_ = ToGrpc(status);
    }
    Pump();
  }

  // Ends the call with `status` as soon as no write is in flight (pending events are dropped).
  void Abort(const grpc::Status& status) {
    uploading_.store(false);
    std::shared_ptr<SmoothJob> job;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!finish_status_) finish_status_ = status;
      cancelled_ = true;
      job = job_;
    }
    if (job) job->Detach();
    Pump();
  }

 private:
  static grpc::Status ResourceExhausted(const std::string& message) {
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, message);
  }
  static grpc::Status InvalidArgument(const std::string& message) {
    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, message);
  }

  void OnHalfClose() {
    uploading_.store(false);
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (finished_ || cancelled_) return;
    }
    if (!params_.has_value()) {
      return Abort(InvalidArgument("the stream ended without a JobSpec: send a spec first, then the mesh"));
    }
    if (upload_.empty()) {
      return Abort(InvalidArgument("no mesh arrived: send the Draco bytes in mesh_chunk messages after the spec"));
    }
    if (service_->draining_.load()) return Abort(ShuttingDown());
    const std::string id = !params_->job_id.empty()
                               ? params_->job_id
                               : absl::StrFormat("%x-%d", service_->start_tag_, service_->next_job_.fetch_add(1));
    auto job = std::make_shared<SmoothJob>(id, std::move(*params_), upload_.TakeBytes(), upload_.TakeHold(),
                                           received_, service_->options_, this);
    {
      std::lock_guard<std::mutex> lock(mu_);
      job_ = job;
    }
    job->set_submitted(Clock::now());
    const std::optional<int> position =
        service_->pool_.TrySubmit([job] { job->Run(); }, [job] { return job->detached(); });
    if (!position.has_value()) {
      return Abort(grpc::Status(
          grpc::StatusCode::RESOURCE_EXHAUSTED,
          absl::StrCat("the job queue is full (", service_->options_.queue_depth, " jobs waiting); retry later")));
    }
    job->set_queue_position(*position);
  }

  // Starts the next write, or Finish, when nothing is in flight.
  void Pump() {
    std::unique_lock<std::mutex> lock(mu_);
    if (write_in_flight_ || finished_) return;
    std::optional<grpc::Status> finish;
    if (cancelled_) {
      finish = finish_status_.value_or(grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"));
    } else if (pending_) {
      out_ = std::move(*pending_);
      pending_.reset();
    } else if (pending_progress_) {  // progress precedes the result it led to
      out_ = std::move(*pending_progress_);
      pending_progress_.reset();
    } else if (have_result_ && result_offset_ < result_.size()) {
      const size_t n = std::min<size_t>(kResultChunkBytes, result_.size() - result_offset_);
      out_.Clear();
      out_.set_result_chunk(result_.substr(result_offset_, n));
      result_offset_ += n;
    } else if (have_result_ && summary_) {
      out_.Clear();
      *out_.mutable_summary() = std::move(*summary_);
      summary_.reset();
      std::string().swap(result_);
    } else if (have_result_) {
      finish = grpc::Status::OK;
    } else if (finish_status_) {
      finish = *finish_status_;
    } else {
      return;
    }
    if (finish) {
      finished_ = true;
      lock.unlock();
      Finish(*finish);
      return;
    }
    write_in_flight_ = true;
    lock.unlock();
    StartWrite(&out_);
  }

  MeshSmootherService* const service_;
  const Clock::time_point received_;
  // Reader state: only touched by reactions, which gRPC serialises for reads.
  v1::SmoothRequest request_;
  std::optional<JobParams> params_;
  UploadBuffer upload_;  // held against the service's memory budget
  // For the idle reaper (another thread): reading the upload, and when the last message came.
  std::atomic<bool> uploading_{false};
  std::atomic<Clock::time_point> last_read_;

  std::mutex mu_;  // guards everything below
  std::shared_ptr<SmoothJob> job_;
  v1::SmoothResponse out_;
  std::optional<v1::SmoothResponse> pending_;           // accepted
  std::optional<v1::SmoothResponse> pending_progress_;  // newest only
  std::string result_;
  size_t result_offset_ = 0;
  std::optional<v1::Summary> summary_;
  bool have_result_ = false;
  std::optional<grpc::Status> finish_status_;
  bool write_in_flight_ = false;
  bool finished_ = false;
  bool cancelled_ = false;
};

MeshSmootherService::MeshSmootherService(const ServerOptions& options)
    : options_(options),
      budget_(options.max_buffered_bytes > 0 ? options.max_buffered_bytes : DefaultBufferedBytes()),
      pool_(options.workers > 0 ? options.workers : HardwareThreads(), options.queue_depth),
      start_tag_(static_cast<uint64_t>(
          std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch())
              .count())) {
  if (options.upload_idle_seconds > 0.0 || options.max_queue_wait_seconds > 0.0) {
    reaper_ = std::thread([this] { Reap(); });
  }
}

MeshSmootherService::~MeshSmootherService() {
  StopReaper();
  pool_.Stop();
}

namespace {

// `seconds` as a clock duration; 0 for "never" (<= 0), capped where a clock would overflow.
Clock::duration Limit(double seconds) {
  if (!(seconds > 0.0)) return Clock::duration::zero();
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::min(seconds, 1e9)));
}

}  // namespace

void MeshSmootherService::Reap() {
  const Clock::duration idle = Limit(options_.upload_idle_seconds);
  const Clock::duration queue_wait = Limit(options_.max_queue_wait_seconds);
  // A call ends between its limit and 1.25 x its limit after it began to wait.
  Clock::duration shortest = std::chrono::hours(1);
  if (idle > Clock::duration::zero()) shortest = std::min(shortest, idle);
  if (queue_wait > Clock::duration::zero()) shortest = std::min(shortest, queue_wait);
  const auto period = std::clamp<Clock::duration>(shortest / 4, std::chrono::milliseconds(10), std::chrono::seconds(1));
  const grpc::Status idle_status(
      grpc::StatusCode::DEADLINE_EXCEEDED,
      absl::StrFormat("no message for %g s: this server ends uploads that stop sending (--upload-idle-seconds); "
                      "send the spec, the whole mesh, then half-close",
                      options_.upload_idle_seconds));
  const grpc::Status queue_status(
      grpc::StatusCode::RESOURCE_EXHAUSTED,
      absl::StrFormat("the job waited %g s for a worker without getting one (--max-queue-wait); this replica is "
                      "saturated: retry later or on another replica",
                      options_.max_queue_wait_seconds));
  std::unique_lock<std::mutex> lock(mu_);
  while (!reaper_stop_) {
    reaper_cv_.wait_for(lock, period);
    const Clock::time_point now = Clock::now();
    for (SmoothReactor* r : reactors_) {  // a reactor is deleted only after Unregister
      if (idle > Clock::duration::zero() && r->IdleSince(now - idle)) {
        r->Abort(idle_status);
      } else if (queue_wait > Clock::duration::zero() && r->QueuedSince(now - queue_wait)) {
        r->Abort(queue_status);
      }
    }
  }
}

void MeshSmootherService::StopReaper() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    reaper_stop_ = true;
  }
  reaper_cv_.notify_all();
  if (reaper_.joinable()) reaper_.join();
}

bool MeshSmootherService::Authorized(const grpc::CallbackServerContext* context) const {
  if (options_.auth_token.empty()) return true;
  const auto& md = context->client_metadata();
  const std::string expected = "Bearer " + options_.auth_token;
  for (auto it = md.find("authorization"); it != md.end() && it->first == "authorization"; ++it) {
    const std::string got(it->second.data(), it->second.size());
    if (got.size() != expected.size()) continue;
    unsigned char diff = 0;  // constant-time comparison
    for (size_t i = 0; i < got.size(); ++i) diff |= static_cast<unsigned char>(got[i] ^ expected[i]);
    if (diff == 0) return true;
  }
  return false;
}

void MeshSmootherService::Register(SmoothReactor* r) {
  std::lock_guard<std::mutex> lock(mu_);
  reactors_.insert(r);
  active_.fetch_add(1);
}

void MeshSmootherService::Unregister(SmoothReactor* r) {
  std::lock_guard<std::mutex> lock(mu_);
  reactors_.erase(r);
  active_.fetch_sub(1);
}

grpc::ServerBidiReactor<v1::SmoothRequest, v1::SmoothResponse>* MeshSmootherService::Smooth(
    grpc::CallbackServerContext* context) {
  return new SmoothReactor(this, context);
}

grpc::ServerUnaryReactor* MeshSmootherService::ListFlows(grpc::CallbackServerContext* context,
                                                         const v1::ListFlowsRequest*,
                                                         v1::ListFlowsResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!Authorized(context)) {
    reactor->Finish(grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "missing or wrong bearer token"));
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
  for (const ParameterInfo& p : CommonParameters(options_.max_iterations)) ToProto(p, response->add_common_parameters());
  response->set_max_iterations(static_cast<uint32_t>(options_.max_iterations));
  reactor->Finish(grpc::Status::OK);
  return reactor;
}

void MeshSmootherService::DrainAndStop(Clock::time_point deadline) {
  draining_.store(true);
  // Uploads and queued jobs end at once: their clients can send them to another replica now
  // rather than after the grace.
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (SmoothReactor* r : reactors_) {
      if (!r->Running()) r->Abort(SmoothReactor::ShuttingDown());
    }
  }
  while (active_.load() > 0 && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  {
    std::lock_guard<std::mutex> lock(mu_);
    for (SmoothReactor* r : reactors_) {
      r->Abort(grpc::Status(grpc::StatusCode::UNAVAILABLE,
                            absl::StrFormat("meshsmoothd shut down; the job was cancelled after the %g s grace period",
                                            options_.grace_seconds)));
    }
  }
  pool_.Stop();  // a cancelled job stops within one iteration
}

}  // namespace meshsmooth::server
