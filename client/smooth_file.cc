#include "client/smooth_file.h"

#include <algorithm>
#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "client/local_run.h"
#include "client/retry.h"
#include "client/smooth_client.h"
#include "client/strength.h"
#include "client/transfer.h"
#include "core/io/mesh_io.h"

namespace meshsmooth::client {
namespace {

// How a job ran, through the service or in memory: its status, or its summary and result.
struct JobRun {
  absl::Status status;
  std::string prefix;  // before the status's message: its code's name, for a status the call ended with
  bool interrupted = false;
  v1::Summary summary;
  std::string result;  // through the service: the result's Draco bytes
  LocalOutcome local;  // in memory: the result's points
};

// Without --server, a mesh file (or builtin:NAME) written to a mesh file other than .drc with
// the default lossless sequential encoding goes to a job in this process in memory. The rest goes
// through the in-process service's codec: quantization and Edgebreaker are Draco's encodings
// of the result, and a .drc or glTF input or output is Draco data itself.
bool RunsInMemory(const SmoothOptions& o, const ConnectionOptions& c, MeshFormat out) {
  if (!c.server.empty() || IsGltfPath(o.input) || IsGltfPath(o.output) || out == MeshFormat::kDraco) return false;
  const absl::StatusOr<MeshFormat> in = FormatFromPath(o.input);
  if (in.ok() && *in == MeshFormat::kDraco) return false;
  return o.quantization_bits == 0 && !o.edgebreaker;
}

// `cancel` registered with `cancels` while the job runs, and a Ctrl-C watcher of its own around it
// when `watch` (a single run).
class CancelScope {
 public:
  CancelScope(JobCancels& cancels, std::function<void()> cancel, bool watch) : cancels_(cancels) {
    id_ = cancels_.Register(std::move(cancel));
    if (watch) watcher_.emplace([this] { cancels_.Cancel(); });
  }
  ~CancelScope() {
    watcher_.reset();
    cancels_.Unregister(id_);
  }
  bool interrupted() { return cancels_.cancelled(); }

 private:
  JobCancels& cancels_;
  int id_ = 0;
  std::optional<InterruptWatcher> watcher_;
};

JobRun RunInMemory(const v1::JobSpec& spec, Upload& upload, const ConnectionOptions& c, JobCancels& cancels,
                   const FileHooks& hooks) {
  JobRun run;
  server::MeshUpload mesh{&upload.kept.positions, &upload.kept.triangles, std::move(upload.strength_values)};
  LocalJob job;
  absl::StatusOr<LocalOutcome> outcome;
  {
    CancelScope scope(
        cancels, [&job] { job.Cancel(); }, hooks.watch_interrupt);
    outcome = job.Run(spec, std::move(mesh), CallDeadline(c), hooks.progress);
    run.interrupted = scope.interrupted();
  }
  if (!outcome.ok()) {
    run.status = outcome.status();
    run.prefix = std::string(absl::StatusCodeToString(run.status.code())) + ": ";
    return run;
  }
  run.summary = std::move(outcome->summary);
  run.local = *std::move(outcome);
  return run;
}

JobRun RunThroughService(const v1::JobSpec& spec, Upload& upload, ServiceLink& service, JobCancels& cancels,
                         const FileHooks& hooks) {
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
    CancelScope scope(
        cancels, [&call] { call.Cancel(); }, hooks.watch_interrupt);
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

FileOutcome Failed(const std::string& prefix, const absl::Status& s, FileOutcome out) {
  out.exit_code = s.code() == absl::StatusCode::kUnavailable ? kExitUnavailable : kExitFailure;
  out.error = absl::StrCat(prefix, s.message());
  return out;
}

}  // namespace

v1::JobSpec SpecFrom(const SmoothOptions& o) {
  v1::JobSpec spec;
  spec.set_job_id(o.job_id);
  if (o.flow != "auto") spec.set_flow(o.flow);  // none named: the server chooses
  spec.set_iterations(o.iterations);
  spec.set_step(o.step);
  spec.set_weights(o.weights == "u1" ? v1::UMBRELLA_WEIGHTS_INVERSE_DISTANCE : v1::UMBRELLA_WEIGHTS_UNIFORM);
  if (o.mu > 0) spec.set_taubin_mu(o.mu);
  if (o.pass_band > 0) spec.set_taubin_pass_band(o.pass_band);
  if (o.tangential_weight >= 0) spec.set_tangential_weight(o.tangential_weight);
  if (o.epsilon > 0) spec.set_epsilon(o.epsilon);
  v1::NormalFilter* nf = spec.mutable_normal_filter();
  if (o.normal_iterations > 0) nf->set_normal_iterations(o.normal_iterations);
  if (o.vertex_iterations > 0) nf->set_vertex_iterations(o.vertex_iterations);
  if (o.sigma_spatial > 0) nf->set_sigma_spatial(o.sigma_spatial);
  if (o.sigma_range > 0) nf->set_sigma_range(o.sigma_range);
  static const std::map<std::string, v1::AdaptiveMode> kModes = {{"none", v1::ADAPTIVE_MODE_NONE},
                                                                 {"constant", v1::ADAPTIVE_MODE_CONSTANT},
                                                                 {"ring1", v1::ADAPTIVE_MODE_RING1},
                                                                 {"ring2", v1::ADAPTIVE_MODE_RING2}};
  spec.mutable_adaptive()->set_mode(kModes.at(o.adaptive));
  spec.mutable_adaptive()->set_threshold(o.threshold);
  spec.mutable_adaptive()->set_recompute_every(o.recompute_every);
  spec.set_boundary(o.boundary == "curve"   ? v1::BOUNDARY_MODE_CURVE
                    : o.boundary == "fixed" ? v1::BOUNDARY_MODE_FIXED
                                            : v1::BOUNDARY_MODE_UNSPECIFIED);
  spec.set_tolerance(o.tolerance);
  spec.mutable_output()->set_quantization_bits(o.quantization_bits);
  spec.mutable_output()->set_edgebreaker(o.edgebreaker);
  if (o.ridges) {
    spec.mutable_features()->set_enabled(true);
    spec.mutable_features()->set_min_abs_curvature(o.ridge_threshold);
  }
  if (o.strength.any()) spec.set_strength_attribute(kStrengthAttribute);
  // Checked before (CheckSmoothOptions).
  if (absl::StatusOr<DisplacementBoundOption> bound = ParseMaxDisplacement(o.max_displacement); bound.ok()) {
    if (bound->in_h) {
      spec.set_max_displacement_h(bound->value);
    } else {
      spec.set_max_displacement(bound->value);
    }
  }
  return spec;
}

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

v1::Summary SummaryWithWarnings(const FileOutcome& outcome) {
  v1::Summary summary;
  for (const std::string& w : outcome.upload_warnings) summary.add_warnings(w);
  for (const std::string& d : outcome.dropped) summary.add_warnings(absl::StrCat("not kept: ", d));
  summary.MergeFrom(outcome.summary);
  return summary;
}

bool EdgebreakerFits(const std::string& input, const std::string& output) {
  // Edgebreaker orders the result's points its own way; a mesh file written from the input's own
  // connectivity (every input but a .drc) needs them in the input's order.
  const absl::StatusOr<MeshFormat> in_format = FormatFromPath(input);
  const absl::StatusOr<MeshFormat> out_format = FormatFromPath(output);
  return IsGltfPath(output) || (out_format.ok() && *out_format == MeshFormat::kDraco) ||
         (in_format.ok() && *in_format == MeshFormat::kDraco);
}

absl::Status CheckInputOutput(const SmoothOptions& o, std::vector<std::string>& warnings) {
  const bool gltf_out = IsGltfPath(o.output);
  if (!gltf_out && IsGltfPath(o.input)) {
    return absl::InvalidArgumentError(
        "a glTF scene (.glb, .gltf) is smoothed into a glTF scene: give -o FILE.glb or FILE.gltf");
  }
  absl::StatusOr<MeshFormat> out_format = gltf_out ? MeshFormat::kDraco : FormatFromPath(o.output);
  if (!out_format.ok()) return out_format.status();
  if (o.edgebreaker && !EdgebreakerFits(o.input, o.output)) {
    return absl::InvalidArgumentError(
        "--edgebreaker reorders the result's vertices; it applies to a .drc or glTF output (or a .drc input): give "
        "-o FILE.drc, or leave --edgebreaker out");
  }
  // Before the upload: a typo in the output's folder must not cost the job.
  if (absl::Status s = CheckOutputPath(o.output); !s.ok()) return s;
  if (o.ridges && (gltf_out || (*out_format != MeshFormat::kPly && *out_format != MeshFormat::kObj &&
                                *out_format != MeshFormat::kDraco))) {
    warnings.push_back(
        "--ridges labels are kept only in .ply and .obj (vertex colours) and .drc (attributes) output; the summary "
        "still counts them");
  }
  return absl::OkStatus();
}

FileOutcome SmoothFile(const SmoothOptions& o, ServiceLink& service, JobCancels& cancels, const FileHooks& hooks) {
  FileOutcome out;
  const ConnectionOptions& c = service.connection();
  const absl::StatusOr<MeshFormat> format = IsGltfPath(o.output) ? MeshFormat::kDraco : FormatFromPath(o.output);
  if (!format.ok()) return Failed("", format.status(), std::move(out));
  const bool in_memory = RunsInMemory(o, c, *format);
  // The attributes go to the service only for a .drc output, which is written as it comes back.
  absl::StatusOr<Upload> upload =
      PrepareUpload(o.input, *format == MeshFormat::kDraco, o.gltf_draco, o.strength, in_memory);
  if (!upload.ok()) return Failed("", upload.status(), std::move(out));
  out.upload_warnings = upload->warnings;
  if (hooks.upload_warnings) hooks.upload_warnings(out.upload_warnings);
  const v1::JobSpec spec = SpecFrom(o);
  JobRun run = in_memory ? RunInMemory(spec, *upload, c, cancels, hooks)
                         : RunThroughService(spec, *upload, service, cancels, hooks);
  if (hooks.job_done) hooks.job_done();
  if (run.interrupted) {
    out.exit_code = kExitInterrupted;
    out.error = "interrupted; the job was cancelled";
    return out;
  }
  if (!run.status.ok()) return Failed(run.prefix, run.status, std::move(out));
  out.dropped = upload->dropped;
  DracoOptions draco;
  draco.quantization_bits = o.quantization_bits;
  draco.method = o.edgebreaker ? DracoMethod::kEdgebreaker : DracoMethod::kSequential;
  const absl::Status written =
      in_memory
          ? WriteResultPoints(*upload, std::move(run.local.points), run.local.labels, o.output, o.ridges, &out.dropped)
          : WriteResult(*upload, run.result, o.output, o.ridges, &out.dropped, o.gltf_draco, draco);
  if (!written.ok()) return Failed("", written, std::move(out));
  out.summary = std::move(run.summary);
  return out;
}

}  // namespace meshsmooth::client
