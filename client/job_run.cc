#include "client/job_run.h"

#include <algorithm>
#include <utility>

#include "client/retry.h"
#include "client/smooth_client.h"

namespace meshsmooth::client {
namespace {

// `cancel` registered with `cancels` while the job runs.
class CancelScope {
 public:
  CancelScope(JobCancels& cancels, std::function<void()> cancel) : cancels_(cancels) {
    id_ = cancels_.Register(std::move(cancel));
  }
  ~CancelScope() { cancels_.Unregister(id_); }
  bool interrupted() { return cancels_.cancelled(); }

 private:
  JobCancels& cancels_;
  int id_ = 0;
};

}  // namespace

absl::StatusOr<v1::MeshSmoother::StubInterface*> ServiceLink::Stub() {
  std::lock_guard<std::mutex> lock(mu_);
  if (!tried_) {
    tried_ = true;
    absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = Connect(connection_, embedded_);
    if (channel.ok()) {
      channel_ = *std::move(channel);
      stub_ = v1::MeshSmoother::NewStub(channel_);
    } else {
      status_ = channel.status();
    }
  }
  if (!status_.ok()) return status_;
  return stub_.get();
}

bool ServiceLink::embedded() {
  std::lock_guard<std::mutex> lock(mu_);
  return embedded_ != nullptr;
}

int JobCancels::Register(std::function<void()> cancel) {
  std::lock_guard<std::mutex> lock(mu_);
  if (cancelled_) cancel();
  jobs_.emplace(next_id_, std::move(cancel));
  return next_id_++;
}

void JobCancels::Unregister(int id) {
  std::lock_guard<std::mutex> lock(mu_);
  jobs_.erase(id);
}

void JobCancels::Cancel() {
  std::lock_guard<std::mutex> lock(mu_);
  cancelled_ = true;
  for (auto& [id, cancel] : jobs_) cancel();
}

bool JobCancels::cancelled() {
  std::lock_guard<std::mutex> lock(mu_);
  return cancelled_;
}

JobRun RunInMemory(const v1::JobSpec& spec, Upload& upload, const ConnectionOptions& c, JobCancels& cancels,
                   const JobHooks& hooks) {
  JobRun run;
  // The triangles go to the job and come back with its result (not a second copy beside them).
  server::MeshUpload mesh{&upload.kept.positions, std::move(upload.kept.triangles), std::move(upload.strength_values)};
  LocalJob job(c.max_memory_bytes);
  absl::StatusOr<LocalOutcome> outcome;
  {
    CancelScope scope(cancels, [&job] { job.Cancel(); });
    outcome = job.Run(spec, std::move(mesh), CallDeadline(c), hooks.progress);
    run.interrupted = scope.interrupted();
  }
  if (!outcome.ok()) {
    run.status = outcome.status();
    run.prefix = std::string(absl::StatusCodeToString(run.status.code())) + ": ";
    return run;
  }
  run.summary = std::move(outcome->summary);
  upload.kept.triangles = std::move(outcome->faces);
  run.local = *std::move(outcome);
  return run;
}

JobRun RunThroughService(const v1::JobSpec& spec, Upload& upload, ServiceLink& service, JobCancels& cancels,
                         const JobHooks& hooks) {
  JobRun run;
  const ConnectionOptions& c = service.connection();
  absl::StatusOr<v1::MeshSmoother::StubInterface*> stub = service.Stub();
  if (!stub.ok()) {
    run.status = stub.status();
    return run;
  }
  RetryPolicy policy;
  // The in-process server has no network to fail between: one attempt, and the upload's bytes
  // go as soon as they are sent (the server holds its own copy while the job runs).
  policy.max_attempts = service.embedded() ? 1 : 1 + std::max(0, c.retries);
  const auto deadline = CallDeadline(c);  // one deadline for every attempt
  RetryingSmooth call(
      policy, [&c, deadline](grpc::ClientContext& ctx) { return PrepareContext(c, ctx, deadline); }, deadline,
      hooks.retry);
  call.ReleaseAfterLastSend([&upload] { std::string().swap(upload.draco); });
  absl::StatusOr<SmoothOutcome> outcome;
  {
    CancelScope scope(cancels, [&call] { call.Cancel(); });
    outcome = call.Run(**stub, spec, upload.draco, hooks.progress);
    run.interrupted = scope.interrupted();
  }
  if (!outcome.ok()) {
    run.prefix = std::string(absl::StatusCodeToString(outcome.status().code())) + ": ";
    run.status = WithConnectionHint(outcome.status(), c);
    return run;
  }
  run.summary = std::move(outcome->summary);
  run.result = std::move(outcome->result);
  return run;
}

}  // namespace meshsmooth::client
