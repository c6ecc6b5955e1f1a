#include "server/smooth_reactor.h"

#include <algorithm>
#include <atomic>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/convert.h"
#include "server/log.h"
#include "server/smooth_job.h"

namespace meshsmooth::server {
namespace {

// One Smooth call. Reads the spec and the chunks, hands the job to the pool, then writes the
// job's events back with one write in flight: accepted, the newest progress (older ones are
// dropped while a write is in flight), result chunks, summary, and Finish exactly once. Job events arrive on the worker
// thread; the job's own mutex is never taken while this reactor's mutex is held.
class SmoothReactor final : public grpc::ServerBidiReactor<v1::SmoothRequest, v1::SmoothResponse>,
                            public JobSink,
                            public AdmittedCall {
 public:
  // `authenticated`: OK, or the status the call ends with at once. `new_job_id` names a job
  // whose spec brings no id.
  SmoothReactor(const grpc::Status& authenticated, grpc::CallbackServerContext* context, Admission& admission,
                WorkerPool& pool, const ServerOptions& options, std::function<std::string()> new_job_id)
      : context_(context),
        peer_(context->peer()),
        admission_(admission),
        pool_(pool),
        options_(options),
        new_job_id_(std::move(new_job_id)),
        received_(Clock::now()),
        upload_(&admission.budget(), options.max_upload_bytes, admission.metrics()),
        last_read_(received_) {
    // Registered whatever the answer: OnDone closes every call.
    const std::optional<Refused> refused = admission_.Open(this);
    if (!authenticated.ok() || refused) {
      Refuse(!authenticated.ok() ? Refused{Refusal::kUnauthenticated, authenticated} : *refused);
      return;
    }
    uploading_.store(true);
    StartRead(&request_);
  }

  // AdmittedCall.
  bool IdleSince(Clock::time_point cutoff) const override { return uploading_.load() && last_read_.load() < cutoff; }
  bool QueuedSince(Clock::time_point cutoff) override {
    std::lock_guard<std::mutex> lock(mu_);
    return job_ != nullptr && !job_->started() && job_->submitted() < cutoff;
  }
  bool Running() override {
    std::lock_guard<std::mutex> lock(mu_);
    return job_ != nullptr && job_->started();
  }
  // Ends the call with `status` as soon as no write is in flight (pending events are dropped).
  void Abort(const grpc::Status& status) override { End(status, /*transient=*/false); }

  void Refuse(const Refused& refused) override {
    admission_.metrics().Refused(refused.reason);
    std::string job_id;
    {
      std::lock_guard<std::mutex> lock(mu_);
      job_id = job_id_;
    }
    if (options_.log_refusals) {
      LogRefusal(options_.log_format, {"Smooth", RefusalName(refused.reason), refused.status, peer_, job_id});
    }
    End(refused.status, IsTransient(refused.reason));
  }

  void OnReadDone(bool ok) override {
    last_read_.store(Clock::now());
    if (!ok) return OnHalfClose();
    const ServerOptions& options = options_;
    switch (request_.kind_case()) {
      case v1::SmoothRequest::kSpec: {
        if (params_.has_value()) {
          return Refuse(InvalidArgument("a second JobSpec arrived: send exactly one spec, first, then the mesh"));
        }
        if (CheckJobId(request_.spec().job_id()).ok()) {  // the log of a refusal names a valid id only
          std::lock_guard<std::mutex> lock(mu_);
          job_id_ = request_.spec().job_id();
        }
        absl::StatusOr<JobParams> params = FromProto(request_.spec(), options.max_iterations);
        if (!params.ok()) return Refuse({Refusal::kInvalidRequest, ToGrpc(params.status())});
        if (!request_.spec().callback_url().empty()) {
          return Refuse(InvalidArgument(
              "callback_url is for kept jobs (Submit): a Smooth call gets its result and summary on the call itself"));
        }
        params_ = std::move(params).value();
        break;
      }
      case v1::SmoothRequest::kMeshChunk: {
        if (!params_.has_value()) {
          return Refuse(InvalidArgument("the first message must be a JobSpec (spec), not a mesh chunk"));
        }
        const std::string& chunk = request_.mesh_chunk();
        // Sizes beyond this server's limits are RESOURCE_EXHAUSTED, as gRPC's own answer to a
        // message above its receive limit (a chunk of more than kMaxReceiveMessageBytes).
        if (static_cast<int64_t>(chunk.size()) > kMaxChunkBytes) {
          return Refuse(admission_.ChunkTooLarge(chunk.size()));
        }
        // The upload's own limit and the server's memory budget.
        if (std::optional<Refused> refused = upload_.Append(chunk)) return Refuse(*refused);
        if (std::optional<Refused> refused = CheckJobSize()) return Refuse(*refused);
        break;
      }
      default:
        return Refuse(InvalidArgument("an empty SmoothRequest (neither spec nor mesh_chunk)"));
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
    admission_.Close(this);
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
      // A newer report of the same phase and flow replaces one not yet written; a change of
      // phase or flow is kept, so the client sees every phase.
      const bool replaces = !pending_progress_.empty() &&
                            pending_progress_.back().progress().phase() == progress.phase() &&
                            pending_progress_.back().progress().flow() == progress.flow();
      if (!replaces) pending_progress_.emplace_back();
      *pending_progress_.back().mutable_progress() = progress;
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

 private:
  // A call that breaks the protocol: INVALID_ARGUMENT.
  static Refused InvalidArgument(const std::string& message) {
    return {Refusal::kInvalidRequest, grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, message)};
  }

  // Once the upload's head holds the counts Draco declares there (the first chunk, unless a
  // large metadata block comes first): the job's memory estimate against --max-job-bytes. Looked
  // for in the first kSizedWithinBytes only; past them the decoder's own checks are left.
  std::optional<Refused> CheckJobSize() {
    if (sized_) return std::nullopt;
    const std::string_view head = upload_.bytes();
    const std::optional<DracoCounts> counts = DracoDeclaredCounts(head);
    sized_ = counts.has_value() || static_cast<int64_t>(head.size()) >= kSizedWithinBytes;
    if (!counts.has_value()) return std::nullopt;
    return admission_.CheckJobMemory(counts->points, counts->faces, *params_);
  }
  static constexpr int64_t kSizedWithinBytes = int64_t{4} << 20;

  // Ends the call with `status` as soon as no write is in flight (pending events are dropped);
  // `transient`: a RESOURCE_EXHAUSTED that is the server's capacity (IsTransient).
  void End(const grpc::Status& status, bool transient) {
    uploading_.store(false);
    std::shared_ptr<SmoothJob> job;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (!finish_status_) {
        finish_status_ = status;
        transient_ = transient;
      }
      cancelled_ = true;
      job = job_;
    }
    if (job) job->Detach();
    Pump();
  }

  void OnHalfClose() {
    uploading_.store(false);
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (finished_ || cancelled_) return;
    }
    if (!params_.has_value()) {
      return Refuse(InvalidArgument("the stream ended without a JobSpec: send a spec first, then the mesh"));
    }
    if (upload_.empty()) {
      return Refuse(InvalidArgument("no mesh arrived: send the Draco bytes in mesh_chunk messages after the spec"));
    }
    if (std::optional<Refused> refused = admission_.CheckNotDraining()) return Refuse(*refused);
    const std::string id = !params_->job_id.empty() ? params_->job_id : new_job_id_();
    auto job = std::make_shared<SmoothJob>(id, std::move(*params_), upload_.TakeBytes(), upload_.TakeHold(), received_,
                                           options_, this, peer_, admission_.metrics());
    {
      std::lock_guard<std::mutex> lock(mu_);
      job_ = job;
      job_id_ = id;
    }
    job->set_submitted(Clock::now());
    const std::optional<int> position = pool_.TrySubmit([job] { job->Run(); }, [job] { return job->detached(); });
    if (!position.has_value()) return Refuse(admission_.QueueFull());
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
    } else if (!pending_progress_.empty()) {  // progress precedes the result it led to
      out_ = std::move(pending_progress_.front());
      pending_progress_.pop_front();
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
      // Whether a retry can help (smoothing.proto): only a refusal for the server's capacity.
      if (finish->error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
        context_->AddTrailingMetadata(kExhaustedKey, transient_ ? kExhaustedTransient : kExhaustedPermanent);
      }
      lock.unlock();
      Finish(*finish);
      return;
    }
    write_in_flight_ = true;
    lock.unlock();
    StartWrite(&out_);
  }

  grpc::CallbackServerContext* const context_;
  const std::string peer_;
  Admission& admission_;
  WorkerPool& pool_;
  const ServerOptions& options_;
  const std::function<std::string()> new_job_id_;
  const Clock::time_point received_;
  // Reader state: only touched by reactions, which gRPC serialises for reads.
  v1::SmoothRequest request_;
  std::optional<JobParams> params_;
  bool sized_ = false;   // the upload's head was read for its counts (CheckJobSize)
  UploadBuffer upload_;  // held against the service's memory budget
  // For the idle reaper (another thread): reading the upload, and when the last message came.
  std::atomic<bool> uploading_{false};
  std::atomic<Clock::time_point> last_read_;

  std::mutex mu_;  // guards everything below
  std::shared_ptr<SmoothJob> job_;
  v1::SmoothResponse out_;
  std::optional<v1::SmoothResponse> pending_;  // accepted
  // Per phase (and flow) of the job, its newest report not yet written: a few at most.
  std::deque<v1::SmoothResponse> pending_progress_;
  std::string result_;
  size_t result_offset_ = 0;
  std::optional<v1::Summary> summary_;
  bool have_result_ = false;
  std::optional<grpc::Status> finish_status_;
  bool transient_ = false;  // finish_status_ is a refusal for the server's capacity
  std::string job_id_;      // once known: the spec's, or the one the server gave the job
  bool write_in_flight_ = false;
  bool finished_ = false;
  bool cancelled_ = false;
};

}  // namespace

grpc::ServerBidiReactor<v1::SmoothRequest, v1::SmoothResponse>* NewSmoothReactor(
    const grpc::Status& authenticated, grpc::CallbackServerContext* context, Admission& admission, WorkerPool& pool,
    const ServerOptions& options, std::function<std::string()> new_job_id) {
  return new SmoothReactor(authenticated, context, admission, pool, options, std::move(new_job_id));
}

}  // namespace meshsmooth::server
