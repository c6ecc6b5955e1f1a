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
#include "core/vec3.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "server/options.h"
#include "server/smooth_job.h"

namespace meshsmooth::client {

// The options of the CLI's in-process service and of a local run: one worker, no log lines.
server::ServerOptions LocalServerOptions();

// What a local run hands back, as the service's result would be decoded: per uploaded vertex.
struct LocalOutcome {
  v1::Summary summary;
  std::vector<Vec3> points;     // the result's positions: the float32 the service sends
  std::vector<uint8_t> labels;  // the ridge labels when the spec asked for them; else empty
};

class LocalJob {
 public:
  // Runs `spec` on `upload` on this thread with LocalServerOptions(); `on_progress` is called on
  // this thread. The statuses the service would end the call with: FromProto's InvalidArgument
  // for a bad spec, the job's own errors; Cancelled once Cancel() is called, DeadlineExceeded
  // ("Deadline Exceeded", as gRPC says it) at `deadline`.
  absl::StatusOr<LocalOutcome> Run(const v1::JobSpec& spec, server::MeshUpload upload,
                                   std::chrono::system_clock::time_point deadline,
                                   const std::function<void(const v1::Progress&)>& on_progress);

  // From another thread: stops the job within one iteration (at once when none runs yet).
  void Cancel();

 private:
  std::mutex mu_;  // guards the two below
  bool cancelled_ = false;
  server::SmoothJob* job_ = nullptr;  // while Run() runs one
};

}  // namespace meshsmooth::client
