#include "client/local_run.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <limits>
#include <string>
#include <thread>
#include <utility>
#include <variant>

#include "absl/strings/str_cat.h"
#include "client/smooth_client.h"
#include "core/features/ridges.h"
#include "core/io/draco_codec.h"
#include "server/convert.h"
#include "server/job_memory.h"
#include "server/service.h"

namespace meshsmooth::client {
namespace {

// A local job's events, all delivered on the thread that runs it.
class Collector final : public server::JobSink {
 public:
  explicit Collector(const std::function<void(const v1::Progress&)>& on_progress) : on_progress_(on_progress) {}

  void OnAccepted(const v1::Accepted&) override {}
  void OnProgress(const v1::Progress& progress) override {
    if (on_progress_) on_progress_(progress);
  }
  void OnResult(std::string, const v1::Summary&) override {
    status_ = absl::InternalError("a local job sent Draco bytes instead of its mesh");
  }
  void OnMeshResult(server::MeshResult result, const v1::Summary& summary) override {
    result_ = std::move(result);
    summary_ = summary;
    status_ = absl::OkStatus();
  }
  void OnError(const absl::Status& status) override { status_ = status; }

  const absl::Status& status() const { return status_; }
  server::MeshResult& result() { return result_; }
  const v1::Summary& summary() const { return summary_; }

 private:
  const std::function<void(const v1::Progress&)>& on_progress_;
  absl::Status status_ = absl::InternalError("a local job ended without a result or an error");
  server::MeshResult result_;
  v1::Summary summary_;
};

// Per uploaded vertex, what the service's result would decode to: its welded vertex's position
// as float32 (DracoMesh::Encode writes each point the float32 of its vertex) and its label.
LocalOutcome ResultPerVertex(server::MeshResult& r, const v1::Summary& summary, size_t vertices) {
  LocalOutcome out;
  out.summary = summary;
  out.faces = std::move(r.upload_faces);
  std::vector<Vec3>& smoothed = r.smoothed.mesh.positions;
  if (r.smoothed.point_to_vertex.empty() && smoothed.size() == vertices) {
    for (Vec3& p : smoothed) p = RoundToFloat(p);  // vertex v is uploaded vertex v: no second copy
    out.points = std::move(smoothed);
  } else {
    out.points.resize(vertices);
    for (size_t v = 0; v < vertices; ++v) out.points[v] = RoundToFloat(smoothed[r.smoothed.VertexOf(v)]);
  }
  for (const GenericAttribute& a : r.attributes) {
    if (a.name != kFeatureLabelAttribute) continue;
    out.labels.resize(vertices);
    std::visit(
        [&](const auto& values) {
          for (size_t v = 0; v < vertices; ++v) out.labels[v] = static_cast<uint8_t>(values[r.smoothed.VertexOf(v)]);
        },
        a.values);
  }
  return out;
}

}  // namespace

// The id of this process's nth local job without one of its own, numbered as the service numbers
// its jobs ("TAG-N", TAG the first local job's start): the jobs of a local batch differ.
std::string NextLocalJobId() {
  static const uint64_t tag = static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count());
  static std::atomic<uint64_t> next{1};
  return server::JobIdOf(tag, next.fetch_add(1));
}

int64_t LocalMemoryBound(int64_t max_memory_bytes) {
  if (max_memory_bytes > 0) return max_memory_bytes;
  return server::AvailableToThisProcess().value_or(0);
}

server::ServerOptions LocalServerOptions(int64_t max_memory_bytes) {
  server::ServerOptions o;
  o.log_jobs = false;
  o.log_refusals = false;  // the call's status tells the user
  o.workers = 1;
  constexpr int64_t kNoBound = std::numeric_limits<int64_t>::max() / 4;
  o.max_upload_bytes = kNoBound;
  o.max_buffered_bytes = kNoBound;
  o.max_vertices = kMaxDracoVertices;
  o.max_job_seconds = 0.0;  // the call's deadline stops it
  o.max_job_bytes = LocalMemoryBound(max_memory_bytes);
  return o;
}

namespace {

// OK, or ResourceExhausted naming both figures when the job's memory estimate is above
// LocalMemoryBound(max_memory_bytes).
absl::Status CheckLocalMemory(const server::JobParams& params, const server::MeshUpload& upload,
                              int64_t max_memory_bytes) {
  const int64_t bound = LocalMemoryBound(max_memory_bytes);
  if (bound <= 0) return absl::OkStatus();
  const auto vertices = static_cast<int64_t>(upload.positions->size());
  const auto faces = static_cast<int64_t>(upload.triangles.size());
  const int64_t needed = server::EstimateJobBytes(vertices, faces, params);
  if (needed <= bound) return absl::OkStatus();
  return absl::ResourceExhaustedError(
      absl::StrCat("the job needs about ", server::FormatBytes(needed), " of memory, estimated for ",
                   server::DescribeJobSize(vertices, faces, params), ", above the ", server::FormatBytes(bound), " ",
                   max_memory_bytes > 0 ? "that --max-memory allows"
                                        : "this machine has available (MemAvailable, and what this process holds)",
                   "; free memory, or smooth a smaller part of the mesh"));
}

}  // namespace

absl::StatusOr<LocalOutcome> LocalJob::Run(const v1::JobSpec& spec, server::MeshUpload upload,
                                           std::chrono::system_clock::time_point deadline,
                                           const std::function<void(const v1::Progress&)>& on_progress) {
  const server::ServerOptions options = LocalServerOptions(max_memory_bytes_);
  // Statuses as they reach a client of the service: through ToGrpc, which cuts long messages.
  const auto as_received = [](const absl::Status& s) { return FromGrpc(server::ToGrpc(s)); };
  absl::StatusOr<server::JobParams> params = server::FromProto(spec, options.max_iterations);
  if (!params.ok()) return as_received(params.status());
  if (absl::Status s = CheckLocalMemory(*params, upload, max_memory_bytes_); !s.ok()) return s;
  const size_t vertices = upload.positions->size();
  const std::string id = !params->job_id.empty() ? params->job_id : NextLocalJobId();
  Collector sink(on_progress);
  server::SmoothJob job(id, *std::move(params), std::move(upload), server::Clock::now(), options, &sink);
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (cancelled_) return absl::CancelledError("the call was cancelled");
    job_ = &job;
  }
  // The deadline, as a call's: the job is stopped there.
  std::mutex done_mu;
  std::condition_variable done_cv;
  bool done = false, timed_out = false;
  std::thread watchdog([&] {
    std::unique_lock<std::mutex> lock(done_mu);
    if (done_cv.wait_until(lock, deadline, [&] { return done; })) return;
    timed_out = true;
    job.Detach();
  });
  job.Run();
  {
    std::lock_guard<std::mutex> lock(done_mu);
    done = true;
  }
  done_cv.notify_all();
  watchdog.join();
  bool cancelled = false;
  {
    std::lock_guard<std::mutex> lock(mu_);
    job_ = nullptr;
    cancelled = cancelled_;
  }
  if (timed_out) return absl::DeadlineExceededError("Deadline Exceeded");
  if (cancelled) return absl::CancelledError("the call was cancelled");
  if (!sink.status().ok()) return as_received(sink.status());
  return ResultPerVertex(sink.result(), sink.summary(), vertices);
}

void LocalJob::Cancel() {
  std::lock_guard<std::mutex> lock(mu_);
  cancelled_ = true;
  if (job_ != nullptr) job_->Detach();
}

}  // namespace meshsmooth::client
