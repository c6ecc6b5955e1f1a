// A job run in this process on a mesh in memory, without the Draco codec: the CLI's local run
// (no --server). The same job as the service runs (server::SmoothJob on a server::MeshUpload,
// with the options of the CLI's in-process server), its events delivered on the calling thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "absl/status/statusor.h"
#include "core/mesh.h"
#include "core/vec3.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "server/options.h"
#include "server/smooth_job.h"

namespace meshsmooth::client {

// The options of the CLI's in-process service and of a local run: one worker, no log lines, and
// none of a network service's limits (upload bytes, buffered bytes, vertices, a job's seconds):
// a local job is bounded by the call's deadline (--timeout) and by memory, max_job_bytes =
// LocalMemoryBound(max_memory_bytes).
server::ServerOptions LocalServerOptions(int64_t max_memory_bytes = 0);

// The memory a local job may need by its estimate: `max_memory_bytes` when above 0 (--max-memory),
// else what this machine has for this process now (server::AvailableToThisProcess: MemAvailable
// and this process's own); 0 (no bound) when neither is known.
int64_t LocalMemoryBound(int64_t max_memory_bytes);

// What a local run hands back, as the service's result would be decoded: per uploaded vertex.
struct LocalOutcome {
  v1::Summary summary;
  std::vector<Vec3> points;     // the result's positions: the float32 the service sends
  std::vector<uint8_t> labels;  // the ridge labels when the spec asked for them; else empty
  std::vector<Triangle> faces;  // the upload's triangles, handed back (server::MeshResult::upload_faces)
};

class LocalJob {
 public:
  // `max_memory_bytes`: LocalMemoryBound's.
  explicit LocalJob(int64_t max_memory_bytes = 0) : max_memory_bytes_(max_memory_bytes) {}

  // Runs `spec` on `upload` on this thread with LocalServerOptions(); `on_progress` is called on
  // this thread. The statuses the service would end the call with: FromProto's InvalidArgument
  // for a bad spec, the job's own errors; Cancelled once Cancel() is called, DeadlineExceeded
  // ("Deadline Exceeded", as gRPC says it) at `deadline`. Before the job: ResourceExhausted
  // naming both figures when its memory estimate (server::EstimateJobBytes) is above
  // LocalMemoryBound.
  absl::StatusOr<LocalOutcome> Run(const v1::JobSpec& spec, server::MeshUpload upload,
                                   std::chrono::system_clock::time_point deadline,
                                   const std::function<void(const v1::Progress&)>& on_progress);

  // From another thread: stops the job within one iteration (at once when none runs yet).
  void Cancel();

 private:
  const int64_t max_memory_bytes_;
  std::mutex mu_;  // guards the two below
  bool cancelled_ = false;
  server::SmoothJob* job_ = nullptr;  // while Run() runs one
};

}  // namespace meshsmooth::client
