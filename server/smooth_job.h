// One smoothing job, free of gRPC: decode the upload, validate, smooth, encode, and report
// each step to a sink (the RPC's reactor). Runs on a worker of the pool; a job on a mesh in
// memory (MeshUpload: the CLI's local run) runs the same steps without the codec.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/flows/flow.h"
#include "core/io/draco_codec.h"
#include "core/mesh.h"
#include "core/topology.h"
#include "core/util/stop_token.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "server/admission.h"
#include "server/convert.h"
#include "server/job_mesh.h"
#include "server/metrics.h"
#include "server/options.h"

namespace meshsmooth::server {

// Receives a job's events, in this order: OnAccepted, OnProgress*, then OnResult (a job on
// Draco bytes) or OnMeshResult (a job on a MeshUpload) or OnError (OnError may also come
// first). Called from the worker thread.
class JobSink {
 public:
  virtual ~JobSink() = default;
  virtual void OnAccepted(const v1::Accepted& accepted) = 0;
  virtual void OnProgress(const v1::Progress& progress) = 0;
  virtual void OnResult(std::string draco_bytes, const v1::Summary& summary) = 0;
  // Only a job constructed with a MeshUpload calls it; by default that is an internal error.
  virtual void OnMeshResult(MeshResult result, const v1::Summary& summary);
  virtual void OnError(const absl::Status& status) = 0;
};

using Clock = std::chrono::steady_clock;

class SmoothJob {
 public:
  // `hold` is the upload's share of the server's memory budget: given back once the upload is
  // decoded and freed (or dropped by Detach()). `peer` is the client's address, for the log; the
  // job's end goes to `metrics` (which must outlive the job).
  SmoothJob(std::string id, JobParams params, std::string upload, BudgetHold hold, Clock::time_point received,
            const ServerOptions& options, JobSink* sink, std::string peer = "", ServiceMetrics& metrics = NoMetrics());
  // A job on a mesh in memory (MeshUpload), which ends with OnMeshResult.
  SmoothJob(std::string id, JobParams params, MeshUpload upload, Clock::time_point received,
            const ServerOptions& options, JobSink* sink);
  ~SmoothJob();

  const std::string& id() const { return id_; }
  void set_queue_position(int position) { queue_position_ = position; }
  void set_submitted(Clock::time_point t) { submitted_.store(t); }
  Clock::time_point submitted() const { return submitted_.load(); }
  // True once a worker took the job (Run() began).
  bool started() const { return started_.load(); }
  // True once Detach() was called: the job will not run, or stops within one iteration.
  bool detached() const { return cancel_.load(); }

  // Runs the whole job; returns when it is done, failed or cancelled.
  void Run();

  // Stops the job within one iteration and drops the sink: no event is delivered after this
  // returns. Frees the upload if the job has not started.
  void Detach();

 private:
  // Calls `fn(sink)` unless the job was detached.
  template <typename Fn>
  void Emit(Fn&& fn);
  // The job has ended: its log entry (unless options.log_jobs is off) and its metrics.
  void Log(const JobReport& report) const;
  // Logs the job with its code and error, counts it, then sends `status` to the sink.
  void Fail(JobReport& report, const absl::Status& status);
  // `status` of a step the job's StopToken ended: past the time limit, a DeadlineExceeded
  // naming the limit and the step (e.g. "decoding the upload"); anything else unchanged.
  absl::Status StepStatus(const absl::Status& status, const char* step) const;
  // ResourceExhausted when the spec asks for work quadratic in the valences (eq. (14)'s second
  // rings, Edgebreaker output) and this mesh's squared valences sum above the server's limit.
  absl::Status CheckQuadraticWork(const Topology& topo) const;

  // The steps of Run(), in order; each stops early once `stop` (the job's cancel flag and
  // --max-job-seconds) fires.
  // Decodes Draco bytes or welds a MeshUpload; takes the upload and frees the bytes.
  absl::StatusOr<std::unique_ptr<JobMesh>> DecodeUpload(const StopToken& stop);
  void SendAccepted(const ValidationReport& validation, int64_t seam_points);
  // The flow (or, for JobSpec.enhance, the enhancement) with what is left of the job's time and
  // the per-vertex `strength` (empty: none), progress throttled to ~10/s; the iterations done so
  // far go to `report` as they complete, an enhancement's result too.
  absl::StatusOr<FlowResult> SmoothMesh(Mesh& mesh, Topology& topo, Clock::time_point decoded, const StopToken& stop,
                                        std::vector<float> strength, JobReport& report);
  // Ridges and ravines as the result's attributes when the spec asks; counts in `report`.
  absl::StatusOr<std::vector<GenericAttribute>> DetectFeaturesIfAsked(const Mesh& mesh, const Topology& topo,
                                                                      const StopToken& stop, JobReport& report) const;
  // The result's Draco bytes; the after metrics and the displacement from `input` (freed before
  // the encoding) go to `report`.
  absl::StatusOr<std::string> EncodeAndMeasure(JobMesh& upload, const Mesh& mesh, const Topology& topo,
                                               std::vector<Vec3> input, const std::vector<GenericAttribute>& attributes,
                                               const StopToken& stop, JobReport& report) const;

  const std::string id_;
  const JobParams params_;
  std::string upload_;
  std::optional<MeshUpload> memory_upload_;  // instead of upload_
  BudgetHold upload_hold_;
  const Clock::time_point received_;
  std::atomic<Clock::time_point> submitted_;
  std::atomic<bool> started_{false};
  std::atomic<int> queue_position_{0};
  const ServerOptions& options_;
  const std::string peer_;
  ServiceMetrics& metrics_;
  std::atomic<bool> cancel_{false};
  std::mutex mu_;  // guards sink_, upload_, memory_upload_ and upload_hold_
  JobSink* sink_;
};

}  // namespace meshsmooth::server
