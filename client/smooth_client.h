// The client side of meshsmooth.v1.MeshSmoother.Smooth: stream a spec and Draco bytes, collect
// accepted, progress, the result and the summary. Used by the CLI and by the service tests.
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "meshsmooth/v1/smoothing.grpc.pb.h"

namespace meshsmooth::client {

struct SmoothOutcome {
  v1::Accepted accepted;
  std::string result;  // Draco bytes of the smoothed mesh
  v1::Summary summary;
  int progress_events = 0;
};

// How far a Smooth call got, also when it failed (whether a retry could lose or repeat output).
struct CallState {
  bool accepted = false;        // Accepted arrived: a worker took the job
  bool result_started = false;  // at least one result chunk arrived
  // The call ended with RESOURCE_EXHAUSTED and the server said it is transient (its capacity:
  // trailing metadata "meshsmooth-exhausted: transient", smoothing.proto), not a limit the
  // request exceeds.
  bool transient_exhaustion = false;
};

// Runs one Smooth call on `context` (set its deadline and metadata before; TryCancel() on it
// from another thread cancels). Sends `draco` in chunks of `chunk_bytes` (<= 1 MiB). Returns
// the server's status as an absl::Status (same codes and message) when the call fails, and
// Internal when the server breaks the message order. `state`, when given, says how far the
// call got. `on_sent`, when given, is called once `draco` has been sent (or the server ended
// the call before): the call no longer reads it.
absl::StatusOr<SmoothOutcome> CallSmooth(v1::MeshSmoother::StubInterface& stub, grpc::ClientContext& context,
                                         const v1::JobSpec& spec, std::string_view draco,
                                         const std::function<void(const v1::Progress&)>& on_progress = nullptr,
                                         size_t chunk_bytes = 1 << 20, CallState* state = nullptr,
                                         const std::function<void()>& on_sent = nullptr);

// gRPC status -> absl::Status (the codes share their numbers).
absl::Status FromGrpc(const grpc::Status& status);

}  // namespace meshsmooth::client
