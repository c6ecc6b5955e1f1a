#include "client/smooth_client.h"

#include <algorithm>

#include "server/admission.h"

namespace meshsmooth::client {

absl::Status FromGrpc(const grpc::Status& status) {
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()), status.error_message());
}

absl::StatusOr<SmoothOutcome> CallSmooth(v1::MeshSmoother::StubInterface& stub, grpc::ClientContext& context,
                                         const v1::JobSpec& spec, std::string_view draco,
                                         const std::function<void(const v1::Progress&)>& on_progress,
                                         size_t chunk_bytes, CallState* state, const std::function<void()>& on_sent) {
  CallState ignored;
  if (state == nullptr) state = &ignored;
  chunk_bytes = std::clamp<size_t>(chunk_bytes, 1, 1 << 20);
  auto stream = stub.Smooth(&context);
  v1::SmoothRequest request;
  *request.mutable_spec() = spec;
  // A failed write means the server has already ended the call: its status says why.
  bool writing = stream->Write(request);
  for (size_t offset = 0; writing && offset < draco.size(); offset += chunk_bytes) {
    request.Clear();
    request.set_mesh_chunk(std::string(draco.substr(offset, chunk_bytes)));
    writing = stream->Write(request);
  }
  if (writing) stream->WritesDone();
  if (on_sent) on_sent();

  SmoothOutcome out;
  enum { kStart, kAccepted, kResult, kSummary } stage = kStart;
  bool order_ok = true;
  v1::SmoothResponse response;
  while (stream->Read(&response)) {
    switch (response.kind_case()) {
      case v1::SmoothResponse::kAccepted:
        order_ok &= stage == kStart;
        out.accepted = response.accepted();
        stage = kAccepted;
        state->accepted = true;
        break;
      case v1::SmoothResponse::kProgress:
        order_ok &= stage == kAccepted;
        ++out.progress_events;
        if (on_progress) on_progress(response.progress());
        break;
      case v1::SmoothResponse::kResultChunk:
        order_ok &= stage == kAccepted || stage == kResult;
        out.result.append(response.result_chunk());
        stage = kResult;
        state->result_started = true;
        break;
      case v1::SmoothResponse::kSummary:
        order_ok &= stage == kResult;
        out.summary = response.summary();
        stage = kSummary;
        break;
      default:
        order_ok = false;
    }
  }
  const grpc::Status status = stream->Finish();
  if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
    const auto& trailers = context.GetServerTrailingMetadata();
    const auto it = trailers.find(server::kExhaustedKey);
    state->transient_exhaustion = it != trailers.end() && it->second == server::kExhaustedTransient;
  }
  if (!status.ok()) return FromGrpc(status);
  if (!order_ok || stage != kSummary) {
    return absl::InternalError("the server broke the response order (accepted, progress, result, summary)");
  }
  if (out.summary.result_bytes() != out.result.size()) {
    return absl::DataLossError("the result's size differs from the one the summary announces");
  }
  return out;
}

}  // namespace meshsmooth::client
