#include "server/smooth_job.h"

#include <cstdio>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/draco_codec.h"
#include "core/features/ridges.h"
#include "core/flows/flow.h"
#include "core/metrics.h"
#include "core/topology.h"

namespace meshsmooth::server {
namespace {

double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// At most ~10 progress events per second reach the client, however fast the iterations run.
constexpr auto kProgressInterval = std::chrono::milliseconds(100);

}  // namespace

SmoothJob::SmoothJob(std::string id, JobParams params, std::string upload, Clock::time_point received,
                     const ServerOptions& options, JobSink* sink)
    : id_(std::move(id)),
      params_(std::move(params)),
      upload_(std::move(upload)),
      received_(received),
      submitted_(received),
      options_(options),
      sink_(sink) {}

template <typename Fn>
void SmoothJob::Emit(Fn&& fn) {
  std::lock_guard<std::mutex> lock(mu_);
  if (sink_ != nullptr) fn(*sink_);
}

void SmoothJob::Detach() {
  cancel_.store(true);
  std::lock_guard<std::mutex> lock(mu_);
  sink_ = nullptr;
  std::string().swap(upload_);
}

void SmoothJob::Log(const std::string& status, int64_t vertices, int iterations, double decode, double queue,
                    double smooth, double encode) const {
  if (!options_.log_jobs) return;
  std::fprintf(stderr,
               "meshsmoothd job=%s flow=%s vertices=%lld iterations=%d/%d status=%s decode=%.3fs queue=%.3fs "
               "smooth=%.3fs encode=%.3fs\n",
               id_.c_str(), params_.flow.flow.c_str(), static_cast<long long>(vertices), iterations,
               params_.flow.iterations, status.c_str(), decode, queue, smooth, encode);
}

void SmoothJob::Run() {
  const Clock::time_point start = Clock::now();
  const double queue_seconds = Seconds(submitted_, start);
  auto fail = [&](const absl::Status& s, int64_t vertices, int iterations, double decode, double smooth) {
    Emit([&](JobSink& sink) { sink.OnError(s); });
    Log(std::string(absl::StatusCodeToString(s.code())), vertices, iterations, decode, queue_seconds, smooth, 0.0);
  };
  if (cancel_.load()) {
    Log("CANCELLED", 0, 0, 0, queue_seconds, 0, 0);
    return;
  }

  std::string upload;
  {
    std::lock_guard<std::mutex> lock(mu_);
    upload.swap(upload_);
  }
  absl::StatusOr<DracoMesh> draco = DracoMesh::Decode(upload);
  std::string().swap(upload);  // the bytes are not needed past decoding
  if (!draco.ok()) return fail(draco.status(), 0, 0, Seconds(start, Clock::now()), 0);
  Mesh mesh = draco->TakeWelded();
  if (mesh.num_vertices() > options_.max_vertices) {
    return fail(absl::ResourceExhaustedError(absl::StrCat("the mesh has ", mesh.num_vertices(),
                                                          " vertices, above this server's limit of ",
                                                          options_.max_vertices)),
                mesh.num_vertices(), 0, Seconds(start, Clock::now()), 0);
  }
  ValidationReport report;
  const Topology topo = BuildTopology(mesh, &report);
  const MeshMetrics before = ComputeMetrics(mesh, topo);
  const Clock::time_point decoded = Clock::now();
  const double decode_seconds = Seconds(start, decoded);

  v1::Accepted accepted;
  accepted.set_job_id(id_);
  accepted.set_queue_position(static_cast<uint32_t>(queue_position_.load()));
  ToProto(report, accepted.mutable_input());
  accepted.mutable_input()->set_seam_points(draco->seam_points());
  Emit([&](JobSink& sink) { sink.OnAccepted(accepted); });

  const std::vector<Vec3> input = mesh.positions;  // for the displacement; the triangles stay put
  FlowParams flow = params_.flow;
  flow.threads = options_.threads_per_job;
  RunControl control;
  control.cancel = &cancel_;
  control.time_budget_seconds = options_.max_job_seconds;
  Clock::time_point last_progress = decoded - kProgressInterval;  // the first iteration is reported
  control.on_progress = [&](const Progress& p) {
    const Clock::time_point now = Clock::now();
    if (now - last_progress < kProgressInterval && p.iteration != p.total) return;
    last_progress = now;
    v1::Progress msg;
    ToProto(p, &msg);
    msg.set_elapsed_seconds(Seconds(decoded, now));
    Emit([&](JobSink& sink) { sink.OnProgress(msg); });
  };
  absl::StatusOr<FlowResult> result = Smooth(mesh, topo, flow, control);
  const Clock::time_point smoothed = Clock::now();
  const double smooth_seconds = Seconds(decoded, smoothed);
  if (!result.ok()) return fail(result.status(), mesh.num_vertices(), 0, decode_seconds, smooth_seconds);
  if (result->stop_reason == StopReason::kTimeBudget) {
    return fail(absl::DeadlineExceededError(absl::StrFormat(
                    "the job ran out of this server's time limit of %g s after %d of %d iterations",
                    options_.max_job_seconds, result->iterations_run, flow.iterations)),
                mesh.num_vertices(), result->iterations_run, decode_seconds, smooth_seconds);
  }

  // Section 5 of the paper: ridges and ravines of the smoothed mesh (same connectivity, so
  // the input's topology serves), sent as generic attributes.
  v1::FeatureCounts counts;
  std::vector<GenericAttribute> attributes;
  if (params_.detect_features) {
    const Clock::time_point t0 = Clock::now();
    const Features features = DetectFeatures(mesh, topo, params_.features);
    counts.set_ridge_vertices(features.ridges);
    counts.set_ravine_vertices(features.ravines);
    counts.set_classified_vertices(features.classified);
    attributes = FeatureAttributes(features);
    counts.set_detect_seconds(Seconds(t0, Clock::now()));
  }
  // Draco encodes on one thread, then the displacement follows there; the summary's "after"
  // metrics take the job's other threads meanwhile, and that one once it is free (all only read
  // the mesh). The metrics on every core beside the encoder's thread would put one thread more
  // than there are cores (docs/performance.md has the figures).
  absl::StatusOr<std::string> encoded;
  absl::StatusOr<Displacement> displacement;
  const MeshMetrics after = ComputeMetricsBeside(
      mesh, topo,
      [&] {
        encoded = draco->Encode(mesh, params_.output, attributes);
        displacement = CompareMeshes(input, mesh);
      },
      options_.threads_per_job);
  const Clock::time_point done = Clock::now();
  if (!encoded.ok()) {
    return fail(encoded.status(), mesh.num_vertices(), result->iterations_run, decode_seconds, smooth_seconds);
  }
  v1::Summary summary;
  summary.set_job_id(id_);
  ToProto(before, summary.mutable_before());
  ToProto(after, summary.mutable_after());
  if (displacement.ok()) {
    summary.set_rms_displacement(displacement->rms);
    summary.set_max_displacement(displacement->max);
    summary.set_flipped_normals(displacement->flipped_normals);
  }
  v1::Timings* t = summary.mutable_timings();
  t->set_decode_seconds(decode_seconds);
  t->set_queue_seconds(queue_seconds);
  t->set_smooth_seconds(smooth_seconds);
  t->set_encode_seconds(Seconds(smoothed, done));
  t->set_total_seconds(Seconds(received_, done));
  ToProto(params_, *result, summary.mutable_parameters());
  summary.set_result_bytes(encoded->size());
  if (params_.detect_features) *summary.mutable_features() = counts;
  Log("OK", mesh.num_vertices(), result->iterations_run, decode_seconds, queue_seconds, smooth_seconds,
      Seconds(smoothed, done));
  Emit([&](JobSink& sink) { sink.OnResult(std::move(*encoded), summary); });
}

}  // namespace meshsmooth::server
