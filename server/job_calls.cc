#include "server/job_calls.h"

#include <algorithm>
#include <mutex>
#include <optional>
#include <string>

#include "absl/strings/str_cat.h"
#include "server/callbacks.h"
#include "server/convert.h"
#include "server/log.h"

// The store's calls are short statements (a chunk of at most 1 MiB committed with one fsync at
// most, in SQLite or on the PostgreSQL server); they run inside the reactions, as a unary handler
// would.
namespace meshsmooth::server {
namespace {

constexpr uint32_t kDefaultPageSize = 100;
constexpr uint32_t kMaxPageSize = 1000;

grpc::Status NoStore() {
  return grpc::Status(
      grpc::StatusCode::UNIMPLEMENTED,
      "this server keeps no jobs: start meshsmoothd with --job-store DIR for Submit and the job methods");
}

grpc::Status Invalid(const std::string& message) { return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, message); }

// OK, or why the call cannot go on: not authenticated, no store, or no job id.
grpc::Status Precheck(const grpc::Status& authenticated, JobRunner* runner, const std::string* job_id = nullptr) {
  if (!authenticated.ok()) return authenticated;
  if (runner == nullptr) return NoStore();
  if (job_id != nullptr && job_id->empty()) return Invalid("job_id is empty");
  return grpc::Status::OK;
}

bool Ended(v1::JobState s) {
  return s == v1::JOB_STATE_SUCCEEDED || s == v1::JOB_STATE_FAILED || s == v1::JOB_STATE_CANCELLED;
}

// One Submit call: the start, the chunks into the store as they come, and at the half-close the
// commit once every byte is there.
class SubmitReactor final : public grpc::ServerReadReactor<v1::SubmitRequest> {
 public:
  SubmitReactor(const grpc::Status& authenticated, JobRunner* runner, const ServerOptions& options,
                v1::SubmitResponse* response)
      : runner_(runner), options_(options), response_(response) {
    if (grpc::Status s = Precheck(authenticated, runner); !s.ok()) {
      End(s);
      return;
    }
    StartRead(&request_);
  }

  void OnReadDone(bool ok) override {
    if (!ok) return OnHalfClose();
    grpc::Status s;
    if (request_.has_start()) {
      s = OnStart(request_.start());
    } else if (request_.has_chunk()) {
      s = OnChunk(request_.chunk());
    } else {
      s = Invalid("an empty SubmitRequest (neither start nor chunk)");
    }
    if (!s.ok()) return End(s);
    if (done_) return End(grpc::Status::OK);  // already committed: nothing to read
    StartRead(&request_);
  }

  void OnDone() override { delete this; }

 private:
  void End(const grpc::Status& status) {
    if (finished_) return;
    finished_ = true;
    Finish(status);
  }

  grpc::Status OnStart(const v1::SubmitStart& start) {
    if (started_) return Invalid("a second SubmitStart: send it once, first, then the chunks");
    if (start.request_id().empty()) return Invalid("request_id is empty: choose one per job (1 to 128 characters)");
    if (absl::Status s = CheckJobId(start.request_id()); !s.ok()) {
      return Invalid(absl::StrCat("request_id: ", s.message()));
    }
    if (!start.spec().job_id().empty()) {
      return Invalid("spec.job_id must be empty in a Submit: the server names the job (Job.job_id)");
    }
    if (absl::StatusOr<JobParams> params = FromProto(start.spec(), options_.max_iterations); !params.ok()) {
      return ToGrpc(params.status());
    }
    if (const std::string& url = start.spec().callback_url(); !url.empty()) {
      if (options_.callback_secret.empty()) {
        return Invalid(
            "callback_url: this server sends no callbacks (start meshsmoothd with --callback-secret-file to sign "
            "them)");
      }
      if (absl::Status s = CheckCallbackUrl(url); !s.ok()) return ToGrpc(s);
    }
    if (start.total_bytes() == 0) return Invalid("total_bytes is 0: an upload holds a Draco mesh");
    if (start.total_bytes() > static_cast<uint64_t>(options_.max_upload_bytes)) {
      return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                          absl::StrCat("an upload of ", start.total_bytes(), " bytes, above this server's limit of ",
                                       options_.max_upload_bytes, " (--max-upload-bytes)"));
    }
    if (start.sha256().size() != 32) {
      return Invalid(absl::StrCat("sha256 holds ", start.sha256().size(), " bytes; a SHA-256 is 32"));
    }
    request_id_ = start.request_id();
    total_ = start.total_bytes();
    JobStore& store = runner_->store();
    const std::optional<UploadState> before = store.QueryUpload(request_id_);
    if (!before.has_value() && !store.MakeRoom(static_cast<int64_t>(total_), options_.job_store_max_bytes)) {
      return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                          absl::StrCat("the job store has no room for ", total_, " bytes more (--job-store-max-bytes ",
                                       options_.job_store_max_bytes, ", every ended job already forgotten)"));
    }
    // Deterministic, so that the same spec sent again compares equal.
    std::string spec;
    {
      google::protobuf::io::StringOutputStream out(&spec);
      google::protobuf::io::CodedOutputStream coded(&out);
      coded.SetSerializationDeterministic(true);
      start.spec().SerializeToCodedStream(&coded);
    }
    absl::StatusOr<UploadState> state = store.StartUpload(request_id_, spec, total_, start.sha256());
    if (!state.ok()) return ToGrpc(state.status());
    started_ = true;
    received_ = state->bytes_received;
    if (!state->job_id.empty()) {  // the same job again: idempotent
      done_ = true;
      return Respond(state->job_id);
    }
    return grpc::Status::OK;
  }

  grpc::Status OnChunk(const v1::UploadChunk& chunk) {
    if (!started_) return Invalid("the first message must be a SubmitStart (start), not a chunk");
    if (static_cast<int64_t>(chunk.data().size()) > kMaxChunkBytes) {
      return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                          absl::StrCat("a chunk of ", chunk.data().size(), " bytes; at most ", kMaxChunkBytes));
    }
    runner_->metrics().JobUploadReceived(static_cast<int64_t>(chunk.data().size()));
    absl::StatusOr<uint64_t> held = runner_->store().AppendChunk(request_id_, chunk.offset(), chunk.data());
    if (!held.ok()) return ToGrpc(held.status());
    received_ = *held;
    return grpc::Status::OK;
  }

  void OnHalfClose() {
    if (finished_) return;
    if (!started_) return End(Invalid("the stream ended without a SubmitStart: send start first, then the chunks"));
    if (received_ < total_) {  // more to come on a later call
      response_->set_request_id(request_id_);
      response_->set_bytes_received(received_);
      return End(grpc::Status::OK);
    }
    const std::string new_id = NewStoredJobId();
    absl::StatusOr<std::string> id = runner_->store().Commit(request_id_, new_id, NowMicros());
    if (!id.ok()) return End(ToGrpc(id.status()));
    if (*id == new_id) {
      LogJobEvent(options_.log_format, "info", "job_submitted", *id,
                  absl::StrCat("submitted (request ", request_id_, ", ", total_, " bytes)"), [&](JsonLine& l) {
                    l.Str("request_id", request_id_).Int("upload_bytes", static_cast<int64_t>(total_));
                  });
    }
    runner_->Wake();
    End(Respond(*id));
  }

  grpc::Status Respond(const std::string& job_id) {
    response_->set_request_id(request_id_);
    response_->set_bytes_received(total_);
    response_->set_committed(true);
    absl::StatusOr<v1::Job> job = runner_->store().Get(job_id);
    if (!job.ok()) return ToGrpc(job.status());
    *response_->mutable_job() = *std::move(job);
    return grpc::Status::OK;
  }

  JobRunner* const runner_;
  const ServerOptions& options_;
  v1::SubmitResponse* const response_;
  v1::SubmitRequest request_;
  std::string request_id_;
  uint64_t total_ = 0;
  uint64_t received_ = 0;
  bool started_ = false;
  bool done_ = false;
  bool finished_ = false;
};

// One WatchJob call: the job's newest state not yet written, one write in flight, Finish after
// the final state's event.
class WatchReactor final : public grpc::ServerWriteReactor<v1::JobEvent>, public JobWatcher {
 public:
  WatchReactor(const grpc::Status& authenticated, JobRunner* runner, const v1::WatchJobRequest& request)
      : runner_(runner), job_id_(request.job_id()), last_sent_(request.after_sequence()) {
    if (grpc::Status s = Precheck(authenticated, runner, &job_id_); !s.ok()) {
      runner_ = nullptr;
      finished_ = true;
      Finish(s);
      return;
    }
    runner_->Watch(job_id_, this);  // before reading the job: no change slips between
    absl::StatusOr<v1::Job> job = runner_->store().Get(job_id_);
    if (!job.ok()) {
      finished_ = true;
      Finish(ToGrpc(job.status()));
      return;
    }
    job->clear_spec();
    Keep(*job);
    if (Ended(job->state())) ended_ = true;  // seen already when after_sequence covers it
    Pump();
  }

  // Called with the runner's watcher lock held: after a cancel the Finish is left to OnCancel,
  // so that OnDone (which takes that lock) never follows from here.
  void OnJobChanged(const v1::Job& job) override {
    Keep(job);
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (cancelled_) return;
    }
    Pump();
  }

  // `job` as the next event unless an event as new was kept or sent.
  void Keep(const v1::Job& job) {
    std::lock_guard<std::mutex> lock(mu_);
    const uint64_t newest = pending_ ? pending_->sequence() : last_sent_;
    if (job.event_sequence() <= newest) return;
    pending_.emplace();
    pending_->set_sequence(job.event_sequence());
    *pending_->mutable_job() = job;
  }

  void OnWriteDone(bool ok) override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      in_flight_ = false;
      if (!ok) cancelled_ = true;
    }
    Pump();
  }

  void OnCancel() override {
    {
      std::lock_guard<std::mutex> lock(mu_);
      cancelled_ = true;
    }
    Pump();
  }

  void OnDone() override {
    if (runner_ != nullptr) runner_->Unwatch(job_id_, this);
    delete this;
  }

  // Starts the next write, or Finish, when nothing is in flight.
  void Pump() {
    std::unique_lock<std::mutex> lock(mu_);
    if (in_flight_ || finished_) return;
    if (cancelled_ || (ended_ && !pending_)) {
      finished_ = true;
      lock.unlock();
      Finish(cancelled_ ? grpc::Status(grpc::StatusCode::CANCELLED, "the watch was cancelled") : grpc::Status::OK);
      return;
    }
    if (!pending_) return;
    out_ = std::move(*pending_);
    pending_.reset();
    last_sent_ = out_.sequence();
    ended_ = Ended(out_.job().state());
    in_flight_ = true;
    lock.unlock();
    StartWrite(&out_);
  }

 private:
  JobRunner* runner_;
  const std::string job_id_;
  std::mutex mu_;
  uint64_t last_sent_;
  std::optional<v1::JobEvent> pending_;
  v1::JobEvent out_;
  bool in_flight_ = false;
  bool ended_ = false;
  bool cancelled_ = false;
  bool finished_ = false;
};

// One FetchResult call: the result's chunks from the offset asked for, read from the store one
// at a time as the writes complete.
class FetchReactor final : public grpc::ServerWriteReactor<v1::FetchResultResponse> {
 public:
  FetchReactor(const grpc::Status& authenticated, JobRunner* runner, const v1::FetchResultRequest& request)
      : runner_(runner), job_id_(request.job_id()), offset_(request.offset()) {
    if (grpc::Status s = Precheck(authenticated, runner, &job_id_); !s.ok()) {
      Finish(s);
      return;
    }
    Next(/*first=*/true);
  }

  void OnWriteDone(bool ok) override {
    if (!ok) return Finish(grpc::Status(grpc::StatusCode::CANCELLED, "the client went away"));
    Next(/*first=*/false);
  }

  void OnDone() override { delete this; }

 private:
  void Next(bool first) {
    absl::StatusOr<JobStore::ResultPiece> piece =
        runner_->store().ReadResult(job_id_, offset_, static_cast<uint64_t>(kResultChunkBytes));
    if (!piece.ok()) return Finish(ToGrpc(piece.status()));
    if (piece->data.empty() && !first) return Finish(grpc::Status::OK);
    out_.set_offset(offset_);
    out_.set_total_bytes(piece->total_bytes);
    out_.set_sha256(piece->sha256);
    offset_ += piece->data.size();
    *out_.mutable_data() = std::move(piece->data);
    StartWrite(&out_);
  }

  JobRunner* const runner_;
  const std::string job_id_;
  uint64_t offset_;
  v1::FetchResultResponse out_;
};

}  // namespace

grpc::ServerReadReactor<v1::SubmitRequest>* NewSubmitReactor(const grpc::Status& authenticated, JobRunner* runner,
                                                             const ServerOptions& options,
                                                             v1::SubmitResponse* response) {
  return new SubmitReactor(authenticated, runner, options, response);
}

grpc::ServerWriteReactor<v1::JobEvent>* NewWatchReactor(const grpc::Status& authenticated, JobRunner* runner,
                                                        const v1::WatchJobRequest& request) {
  return new WatchReactor(authenticated, runner, request);
}

grpc::ServerWriteReactor<v1::FetchResultResponse>* NewFetchReactor(const grpc::Status& authenticated, JobRunner* runner,
                                                                   const v1::FetchResultRequest& request) {
  return new FetchReactor(authenticated, runner, request);
}

grpc::Status QueryUpload(JobRunner* runner, const v1::QueryUploadRequest& request, v1::SubmitResponse* response) {
  if (runner == nullptr) return NoStore();
  response->set_request_id(request.request_id());
  const std::optional<UploadState> state = runner->store().QueryUpload(request.request_id());
  if (!state.has_value()) return grpc::Status::OK;
  response->set_bytes_received(state->bytes_received);
  if (!state->job_id.empty()) {
    absl::StatusOr<v1::Job> job = runner->store().Get(state->job_id);
    if (job.ok()) {
      response->set_committed(true);
      *response->mutable_job() = *std::move(job);
    }
  }
  return grpc::Status::OK;
}

grpc::Status GetJob(JobRunner* runner, const v1::GetJobRequest& request, v1::Job* response) {
  if (grpc::Status s = Precheck(grpc::Status::OK, runner, &request.job_id()); !s.ok()) return s;
  absl::StatusOr<v1::Job> job = runner->store().Get(request.job_id());
  if (!job.ok()) return ToGrpc(job.status());
  *response = *std::move(job);
  return grpc::Status::OK;
}

grpc::Status ListJobs(JobRunner* runner, const v1::ListJobsRequest& request, v1::ListJobsResponse* response) {
  if (runner == nullptr) return NoStore();
  std::vector<v1::JobState> states;
  for (int s : request.states()) states.push_back(static_cast<v1::JobState>(s));
  const uint32_t size = request.page_size() == 0 ? kDefaultPageSize : std::min(request.page_size(), kMaxPageSize);
  std::string next;
  for (v1::Job& j : runner->store().List(states, request.page_token(), static_cast<int>(size), &next)) {
    *response->add_jobs() = std::move(j);
  }
  response->set_next_page_token(next);
  return grpc::Status::OK;
}

grpc::Status CancelJob(JobRunner* runner, const v1::CancelJobRequest& request, v1::Job* response) {
  if (grpc::Status s = Precheck(grpc::Status::OK, runner, &request.job_id()); !s.ok()) return s;
  absl::StatusOr<v1::Job> job = runner->Cancel(request.job_id());
  if (!job.ok()) return ToGrpc(job.status());
  *response = *std::move(job);
  return grpc::Status::OK;
}

grpc::Status DeleteJob(JobRunner* runner, const v1::DeleteJobRequest& request) {
  if (grpc::Status s = Precheck(grpc::Status::OK, runner, &request.job_id()); !s.ok()) return s;
  return ToGrpc(runner->Delete(request.job_id()));
}

}  // namespace meshsmooth::server
