#include "server/smooth_job.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/features/ridges.h"
#include "core/flows/flow.h"
#include "core/io/coordinates.h"
#include "core/job/enhance.h"
#include "core/measure/metrics.h"
#include "core/topology.h"
#include "server/log.h"

namespace meshsmooth::server {
namespace {

double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// At most ~10 progress events per second reach the client, however fast the iterations run.
constexpr auto kProgressInterval = std::chrono::milliseconds(100);

// Work quadratic in a vertex's valence (SquaredValenceSum) is allowed up to this many times the
// work linear in it (the ring entries), or up to kQuadraticWorkFloor in all: eq. (14)'s second
// rings visit it per recompute, and Draco's Edgebreaker encoder, whose corner table searches
// each vertex's edges, spends as much (0.55 s at valence 60,000, 2.2 s at 120,000), both
// without a point to stop at. Ordinary meshes sum ~6-7 per ring entry.
constexpr int64_t kQuadraticWorkPerRingEntry = 64;
constexpr int64_t kQuadraticWorkFloor = int64_t{1} << 26;

// The job's deadline: `seconds` after `start`; none for 0 (or anything a clock cannot hold).
Clock::time_point Deadline(Clock::time_point start, double seconds) {
  if (!(seconds > 0.0) || seconds > 1e9) return Clock::time_point::max();
  return start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

// JobSpec.strength_attribute's values, one per vertex of the upload (empty when the spec names
// none); InvalidArgument naming the field for an attribute the job cannot take.
absl::StatusOr<std::vector<float>> ReadStrength(const JobMesh& upload, const std::string& name) {
  if (name.empty()) return std::vector<float>{};
  absl::StatusOr<std::vector<float>> values = upload.VertexValues(name);
  absl::Status s = values.status();
  if (s.ok()) s = ValidateStrength(*values, static_cast<int32_t>(values->size()));
  if (!s.ok()) return absl::InvalidArgumentError(absl::StrCat("strength_attribute '", name, "': ", s.message()));
  return values;
}

}  // namespace

void JobSink::OnMeshResult(MeshResult, const v1::Summary&) {
  OnError(absl::InternalError("a job on a mesh in memory reached a sink that takes Draco bytes only"));
}

SmoothJob::SmoothJob(std::string id, JobParams params, std::string upload, BudgetHold hold, Clock::time_point received,
                     const ServerOptions& options, JobSink* sink, std::string peer, ServiceMetrics& metrics)
    : id_(std::move(id)),
      params_(std::move(params)),
      upload_(std::move(upload)),
      upload_hold_(std::move(hold)),
      received_(received),
      submitted_(received),
      options_(options),
      peer_(std::move(peer)),
      metrics_(metrics),
      sink_(sink) {}

SmoothJob::SmoothJob(std::string id, JobParams params, MeshUpload upload, Clock::time_point received,
                     const ServerOptions& options, JobSink* sink)
    : id_(std::move(id)),
      params_(std::move(params)),
      memory_upload_(std::move(upload)),
      received_(received),
      submitted_(received),
      options_(options),
      metrics_(NoMetrics()),
      sink_(sink) {}

SmoothJob::~SmoothJob() = default;

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
  memory_upload_.reset();
  upload_hold_.Release();
}

void SmoothJob::Log(const JobReport& report) const {
  if (options_.log_jobs) LogJob(options_.log_format, report, params_, peer_);
  metrics_.JobEnded(report, params_);
}

void SmoothJob::Fail(JobReport& report, const absl::Status& status) {
  report.status = std::string(absl::StatusCodeToString(status.code()));
  report.error = std::string(status.message());
  Log(report);  // first, as for a result: a client that sees the status finds the job counted
  Emit([&](JobSink& sink) { sink.OnError(status); });
}

absl::Status SmoothJob::StepStatus(const absl::Status& status, const char* step) const {
  if (status.code() != absl::StatusCode::kDeadlineExceeded) return status;
  return absl::DeadlineExceededError(
      absl::StrFormat("the job ran out of this server's time limit of %g s while %s", options_.max_job_seconds, step));
}

absl::Status SmoothJob::CheckQuadraticWork(const Topology& topo) const {
  const bool ring2 = params_.flow.adaptive == AdaptiveMode::kRing2;
  const bool edgebreaker = params_.output.method == DracoMethod::kEdgebreaker;
  if (!ring2 && !edgebreaker) return absl::OkStatus();
  const int64_t work = SquaredValenceSum(topo);
  const int64_t limit =
      std::max(kQuadraticWorkFloor, kQuadraticWorkPerRingEntry * static_cast<int64_t>(topo.ring.size()));
  if (work <= limit) return absl::OkStatus();
  int32_t valence = 0;
  for (int32_t v = 0; v < topo.num_vertices(); ++v) valence = std::max(valence, topo.valence(v));
  return absl::ResourceExhaustedError(absl::StrCat(
      ring2 ? "adaptive.mode ADAPTIVE_MODE_RING2" : "Edgebreaker output", " costs the sum of the squared valences, ",
      work, " for this mesh (a vertex of valence ", valence, "), above this server's limit of ", limit, " for it; ",
      ring2 ? "use ADAPTIVE_MODE_RING1" : "ask for sequential output"));
}

absl::StatusOr<std::unique_ptr<JobMesh>> SmoothJob::DecodeUpload(const StopToken& stop) {
  std::string upload;
  std::optional<MeshUpload> memory;
  BudgetHold hold;
  {
    std::lock_guard<std::mutex> lock(mu_);
    upload.swap(upload_);
    memory.swap(memory_upload_);
    hold = std::move(upload_hold_);
  }
  if (memory.has_value()) {
    if (absl::Status s = stop.Check(); !s.ok()) return s;
    return JobMeshInMemory(*std::move(memory));
  }
  absl::StatusOr<DracoMesh> draco = DracoMesh::Decode(upload, stop, options_.max_vertices);
  std::string().swap(upload);  // the bytes are not needed past decoding
  hold.Release();
  if (!draco.ok()) return draco.status();
  return JobMeshOf(*std::move(draco));
}

void SmoothJob::SendAccepted(const ValidationReport& validation, int64_t seam_points) {
  v1::Accepted accepted;
  accepted.set_job_id(id_);
  accepted.set_queue_position(static_cast<uint32_t>(queue_position_.load()));
  ToProto(validation, accepted.mutable_input());
  accepted.mutable_input()->set_seam_points(seam_points);
  Emit([&](JobSink& sink) { sink.OnAccepted(accepted); });
}

absl::StatusOr<FlowResult> SmoothJob::SmoothMesh(Mesh& mesh, Topology& topo, Clock::time_point decoded,
                                                 const StopToken& stop, std::vector<float> strength,
                                                 JobReport& report) {
  FlowParams flow = params_.flow;
  flow.threads = options_.threads_per_job;
  flow.strength = std::move(strength);
  RunControl control;
  control.stop = stop;                                            // the job's cancel flag and what is left of its time
  Clock::time_point last_progress = decoded - kProgressInterval;  // the first iteration is reported
  control.on_progress = [&](const Progress& p) {
    const bool smoothing = p.phase == Phase::kSmoothing;
    if (smoothing) {  // what the log says if the run ends early
      report.flow.flow = p.flow;
      report.flow.iterations_run = p.iteration;
    }
    const Clock::time_point now = Clock::now();
    // Every change of phase, a smoothing's first and last iteration, and at most one report an
    // interval between.
    const bool milestone = !smoothing || p.iteration == 1 || p.iteration == p.total;
    if (now - last_progress < kProgressInterval && !milestone) return;
    last_progress = now;
    v1::Progress msg;
    ToProto(p, &msg);
    msg.set_elapsed_seconds(Seconds(decoded, now));
    Emit([&](JobSink& sink) { sink.OnProgress(msg); });
  };
  if (!params_.enhance.has_value()) return Smooth(mesh, topo, flow, control);
  EnhanceParams enhance = *params_.enhance;
  enhance.strength = std::move(flow.strength);
  enhance.threads = flow.threads;
  absl::StatusOr<EnhanceResult> enhanced = Enhance(mesh, topo, enhance, control);
  if (!enhanced.ok()) return enhanced.status();
  FlowResult result = enhanced->smoothing.value_or(FlowResult{});
  result.mean_edge_length = enhanced->mean_edge_length;
  report.enhanced = *std::move(enhanced);
  return result;
}

absl::StatusOr<std::vector<GenericAttribute>> SmoothJob::DetectFeaturesIfAsked(const Mesh& mesh, const Topology& topo,
                                                                               const StopToken& stop,
                                                                               JobReport& report) const {
  if (!params_.detect_features) return std::vector<GenericAttribute>{};
  const Clock::time_point t0 = Clock::now();
  const Features features = DetectFeatures(mesh, topo, params_.features, stop);
  if (absl::Status s = stop.Check(); !s.ok()) return StepStatus(s, "detecting ridges and ravines");
  report.features = FeatureSummary{features.ridges, features.ravines, features.classified, 0.0};
  std::vector<GenericAttribute> attributes = FeatureAttributes(features);
  report.features->detect_seconds = Seconds(t0, Clock::now());
  return attributes;
}

absl::StatusOr<std::string> SmoothJob::EncodeAndMeasure(JobMesh& upload, const Mesh& mesh, const Topology& topo,
                                                        std::vector<Vec3> input,
                                                        const std::vector<GenericAttribute>& attributes,
                                                        const StopToken& stop, JobReport& report) const {
  // The displacement, then Draco's encoding, on one thread; the summary's "after" metrics take
  // the job's other threads meanwhile, and that one once it is free (all only read the mesh).
  // The metrics on every core beside the encoder's thread would put one thread more than there
  // are cores (docs/decisions.md, "Speed", has the figures). The input's positions go before the
  // encoding: the encoder's mesh and bytes make the job's peak (24 bytes a vertex less).
  absl::StatusOr<std::string> encoded;
  absl::StatusOr<Displacement> displacement;
  report.after = ComputeMetricsBeside(
      mesh, topo,
      [&] {
        displacement = CompareMeshes(input, mesh, report.flow.displacement_bound);
        std::vector<Vec3>().swap(input);
        encoded = upload.Encode(mesh, params_.output, attributes, stop);
      },
      options_.threads_per_job, stop);
  if (displacement.ok()) report.displacement = *displacement;
  if (absl::Status s = stop.Check(); !s.ok()) return StepStatus(s, "encoding the result");
  return encoded;
}

void SmoothJob::Run() {
  started_.store(true);
  const Clock::time_point start = Clock::now();
  // --max-job-seconds bounds the job's whole time on this worker: every long step polls it.
  const StopToken stop(&cancel_, Deadline(start, options_.max_job_seconds));
  JobReport report;
  report.job_id = id_;
  report.queue_seconds = Seconds(submitted_.load(), start);
  if (cancel_.load()) {  // given up while it waited: logged, not counted as a job run
    report.status = "CANCELLED";
    report.error = "the call ended before a worker took the job";
    if (options_.log_jobs) LogJob(options_.log_format, report, params_, peer_);
    return;
  }

  absl::StatusOr<std::unique_ptr<JobMesh>> upload = DecodeUpload(stop);
  if (!upload.ok()) {
    report.decode_seconds = Seconds(start, Clock::now());
    return Fail(report, StepStatus(upload.status(), "decoding the upload"));
  }
  JobMesh& uploaded = **upload;
  Mesh mesh = uploaded.TakeWelded();
  report.vertices = mesh.num_vertices();
  if (mesh.num_vertices() > options_.max_vertices) {
    report.decode_seconds = Seconds(start, Clock::now());
    return Fail(report, absl::ResourceExhaustedError(absl::StrCat("the mesh has ", mesh.num_vertices(),
                                                                  " vertices, above this server's limit of ",
                                                                  options_.max_vertices, " (--max-vertices)")));
  }
  absl::StatusOr<std::vector<float>> strength = ReadStrength(uploaded, params_.strength_attribute);
  if (!strength.ok()) {
    report.decode_seconds = Seconds(start, Clock::now());
    return Fail(report, strength.status());
  }
  // An output the encoder would refuse is refused before the smoothing it would waste.
  if (absl::Status s = uploaded.CheckEncodable(params_.output); !s.ok()) {
    report.decode_seconds = Seconds(start, Clock::now());
    return Fail(report, s);
  }
  ValidationReport validation;
  Topology topo = BuildTopology(mesh, &validation, stop);
  if (stop.Fired()) {
    report.decode_seconds = Seconds(start, Clock::now());
    return Fail(report, StepStatus(stop.Check(), "validating the mesh"));
  }
  if (absl::Status s = CheckQuadraticWork(topo); !s.ok()) {
    report.decode_seconds = Seconds(start, Clock::now());
    return Fail(report, s);
  }
  report.before = ComputeMetrics(mesh, topo, stop);
  if (std::optional<std::string> w = CoarseCoordinatesWarning(mesh.positions, report.before.edge_length_mean)) {
    report.warnings.push_back(std::move(*w));
  }
  const Clock::time_point decoded = Clock::now();
  report.decode_seconds = Seconds(start, decoded);
  if (absl::Status s = stop.Check(); !s.ok()) return Fail(report, StepStatus(s, "validating the mesh"));
  SendAccepted(validation, uploaded.seam_points());

  absl::StatusOr<FlowResult> result = SmoothMesh(mesh, topo, decoded, stop, *std::move(strength), report);
  const Clock::time_point smoothed = Clock::now();
  report.smooth_seconds = Seconds(decoded, smoothed);
  if (!result.ok()) return Fail(report, result.status());
  report.flow = *result;
  if (result->stop_reason == StopReason::kTimeBudget) {
    return Fail(report, absl::DeadlineExceededError(absl::StrFormat(
                            "the job ran out of this server's time limit of %g s after %d of %d iterations",
                            options_.max_job_seconds, result->iterations_run, params_.flow.iterations)));
  }

  // Section 5 of the paper: ridges and ravines of the smoothed mesh (same connectivity, so
  // the input's topology serves), sent as generic attributes.
  absl::StatusOr<std::vector<GenericAttribute>> attributes = DetectFeaturesIfAsked(mesh, topo, stop, report);
  if (!attributes.ok()) return Fail(report, attributes.status());
  {
    v1::Progress writing;
    writing.set_phase(v1::PROGRESS_PHASE_WRITING);
    writing.set_flow(std::string(FlowName(result->flow)));
    writing.set_elapsed_seconds(Seconds(decoded, Clock::now()));
    Emit([&](JobSink& sink) { sink.OnProgress(writing); });
  }
  // The input's positions for the displacement, made anew rather than kept through the run.
  absl::StatusOr<std::string> encoded =
      EncodeAndMeasure(uploaded, mesh, topo, uploaded.InputPositions(), *attributes, stop, report);
  const Clock::time_point done = Clock::now();
  report.encode_seconds = Seconds(smoothed, done);
  if (!encoded.ok()) return Fail(report, encoded.status());
  report.total_seconds = Seconds(received_, done);
  report.result_bytes = encoded->size();
  const v1::Summary summary = MakeSummary(report, params_);
  Log(report);
  if (std::optional<MeshResult> out = uploaded.TakeResult(std::move(mesh), *std::move(attributes))) {
    Emit([&](JobSink& sink) { sink.OnMeshResult(*std::move(out), summary); });
    return;
  }
  Emit([&](JobSink& sink) { sink.OnResult(std::move(*encoded), summary); });
}

}  // namespace meshsmooth::server
