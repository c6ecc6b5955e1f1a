// One smoothing job on an Upload, run in this process on the mesh in memory (LocalJob) or
// through the service (a meshsmoothd, or the in-process server: the Draco codec both ways), as
// the CLI (a single file and each file of a batch: smooth_file.h) and the Python package run it;
// the connection the jobs share, and how another thread cancels them.
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/connection.h"
#include "client/local_run.h"
#include "client/transfer.h"
#include "meshsmooth/v1/smoothing.grpc.pb.h"
#include "meshsmooth/v1/smoothing.pb.h"

namespace meshsmooth::client {

// The service for the jobs that do not run in memory: --server's channel, or the same service
// started in this process when there is no --server. Connected at the first job that needs it
// and shared by every job after it: one channel for a whole batch. Thread-safe.
class ServiceLink {
 public:
  explicit ServiceLink(const ConnectionOptions& connection) : connection_(connection) {}

  // The stub on the shared channel; Connect()'s errors (the same for every call).
  absl::StatusOr<v1::MeshSmoother::StubInterface*> Stub();
  bool embedded();  // the in-process server, which has no network to retry over
  const ConnectionOptions& connection() const { return connection_; }

 private:
  const ConnectionOptions& connection_;
  std::mutex mu_;  // guards the members below
  bool tried_ = false;
  absl::Status status_;
  std::unique_ptr<server::Server> embedded_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::MeshSmoother::Stub> stub_;
};

// Ctrl-C for the jobs in flight (the caller watches for it: the CLI's InterruptWatcher, Python's
// signal handlers; nothing here touches signals): once Cancel() is called, every job registered then and every
// job registered afterwards is cancelled (the call on the server, a job in memory within one
// iteration). Thread-safe.
class JobCancels {
 public:
  // Registers `cancel` until the returned id is unregistered; calls it at once when Cancel()
  // came before.
  int Register(std::function<void()> cancel);
  void Unregister(int id);
  void Cancel();
  bool cancelled();

 private:
  std::mutex mu_;  // guards the members below
  bool cancelled_ = false;
  int next_id_ = 0;
  std::map<int, std::function<void()>> jobs_;
};

// What a job tells its caller along the way; any may be empty.
struct JobHooks {
  std::function<void(const v1::Progress&)> progress;  // called on the job's thread
  // A failed attempt of the call through the service, before the wait for its retry.
  std::function<void(int retry, const absl::Status& status, std::chrono::milliseconds wait)> retry;
};

// How a job ran, through the service or in memory: its status, or its summary and result.
struct JobRun {
  absl::Status status;
  std::string prefix;        // before the status's message: its code's name, for a status the call ended with
  bool interrupted = false;  // cancelled through `cancels`
  v1::Summary summary;
  std::string result;  // through the service: the result's Draco bytes
  LocalOutcome local;  // in memory: the result's points
};

// The job `spec` on `upload` (prepared with `in_memory`: PrepareUpload, UploadMesh) in this
// process, with the options of the CLI's in-process server, its deadline from `connection`. The
// job is registered with `cancels` while it runs. The result is JobRun::local. The upload's
// triangles are handed to the job and back (upload.kept holds them again once it succeeded; a
// failed job's upload is not written from).
JobRun RunInMemory(const v1::JobSpec& spec, Upload& upload, const ConnectionOptions& connection, JobCancels& cancels,
                   const JobHooks& hooks);

// The job `spec` on `upload`'s Draco bytes through `service`, retried as RetryingSmooth retries
// it within one deadline. The upload's bytes are released once the last attempt has sent them.
// The job is registered with `cancels` while it runs. The result is JobRun::result; a failed
// call's status carries WithConnectionHint's hint.
JobRun RunThroughService(const v1::JobSpec& spec, Upload& upload, ServiceLink& service, JobCancels& cancels,
                         const JobHooks& hooks);

}  // namespace meshsmooth::client
