#include "client/commands.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/inputs.h"
#include "client/json.h"
#include "client/local_run.h"
#include "client/report.h"
#include "client/retry.h"
#include "client/smooth_client.h"
#include "client/transfer.h"
#include "core/features/ridges.h"
#include "core/io/mesh_io.h"
#include "core/measure/metrics.h"
#include "core/render/png.h"
#include "core/render/render.h"
#include "core/topology.h"
#include "server/convert.h"

namespace meshsmooth::client {
namespace {

int ExitCodeFor(const absl::Status& s) {
  if (s.code() == absl::StatusCode::kUnavailable) return kExitUnavailable;
  return kExitFailure;
}

// Prints "meshsmooth: <what><message>" and returns the exit code for `s`.
int Fail(const std::string& what, const absl::Status& s) {
  std::cerr << "meshsmooth: " << what << s.message() << "\n";
  return ExitCodeFor(s);
}

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

}  // namespace

absl::StatusOr<DisplacementBoundOption> ParseMaxDisplacement(const std::string& text) {
  DisplacementBoundOption bound;
  if (text.empty()) return bound;
  std::string number = text;
  if (number.back() == 'h') {
    bound.in_h = true;
    number.pop_back();
  }
  if (!absl::SimpleAtod(number, &bound.value) || !std::isfinite(bound.value) || bound.value < 0.0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--max-displacement: '", text,
        "' is not a bound; give a finite number >= 0 in mesh units (0.02) or in mean edge lengths (0.5h)"));
  }
  return bound;
}

absl::Status CheckSmoothOptions(const SmoothOptions& options) {
  if (absl::Status s = CheckStrengthOptions(options.strength); !s.ok()) return s;
  if (absl::Status s = ParseMaxDisplacement(options.max_displacement).status(); !s.ok()) return s;
  v1::JobSpec spec = SpecFrom(options);
  spec.clear_job_id();
  return server::FromProto(spec, std::numeric_limits<int>::max()).status();
}

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

JobRun RunInMemory(const v1::JobSpec& spec, Upload& upload, const ConnectionOptions& c, ProgressPrinter& progress) {
  JobRun run;
  server::MeshUpload mesh{&upload.kept.positions, &upload.kept.triangles, std::move(upload.strength_values)};
  LocalJob job;
  absl::StatusOr<LocalOutcome> outcome;
  {
    InterruptWatcher watcher([&job] { job.Cancel(); });
    outcome = job.Run(spec, std::move(mesh), CallDeadline(c), std::ref(progress));
    run.interrupted = watcher.interrupted();
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

JobRun RunThroughService(const v1::JobSpec& spec, Upload& upload, const ConnectionOptions& c, bool quiet,
                         ProgressPrinter& progress) {
  JobRun run;
  std::unique_ptr<server::Server> embedded;
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = Connect(c, embedded);
  if (!channel.ok()) {
    run.status = channel.status();
    return run;
  }
  auto stub = v1::MeshSmoother::NewStub(*channel);
  RetryPolicy policy;
  // The in-process server has no network to fail between: one attempt, and the upload's bytes
  // go as soon as they are sent (the server holds its own copy while the job runs).
  policy.max_attempts = embedded != nullptr ? 1 : 1 + std::max(0, c.retries);
  const auto deadline = CallDeadline(c);  // one deadline for every attempt
  RetryingSmooth call(
      policy, [&c, deadline](grpc::ClientContext& ctx) { return PrepareContext(c, ctx, deadline); }, deadline,
      [quiet](int retry, const absl::Status& s, std::chrono::milliseconds wait) {
        if (quiet) return;
        std::fprintf(stderr, "meshsmooth: attempt %d failed (%s: %s); retrying in %.1f s\n", retry,
                     std::string(absl::StatusCodeToString(s.code())).c_str(), std::string(s.message()).c_str(),
                     static_cast<double>(wait.count()) / 1000.0);
      });
  call.ReleaseAfterLastSend([&upload] { std::string().swap(upload.draco); });
  absl::StatusOr<SmoothOutcome> outcome;
  {
    InterruptWatcher watcher([&call] { call.Cancel(); });
    outcome = call.Run(*stub, spec, upload.draco, std::ref(progress));
    run.interrupted = watcher.interrupted();
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

}  // namespace

int RunSmooth(const SmoothOptions& o, const ConnectionOptions& c) {
  const bool gltf_out = IsGltfPath(o.output);
  if (!gltf_out && IsGltfPath(o.input)) {
    std::cerr
        << "meshsmooth: a glTF scene (.glb, .gltf) is smoothed into a glTF scene: give -o FILE.glb or FILE.gltf\n";
    return kExitUsage;
  }
  absl::StatusOr<MeshFormat> out_format = gltf_out ? MeshFormat::kDraco : FormatFromPath(o.output);
  if (!out_format.ok()) return Fail("", out_format.status());
  // Edgebreaker orders the result's points its own way; a mesh file written from the input's own
  // connectivity (every input but a .drc) needs them in the input's order.
  const absl::StatusOr<MeshFormat> in_format = FormatFromPath(o.input);
  const bool draco_in = in_format.ok() && *in_format == MeshFormat::kDraco;
  if (o.edgebreaker && !gltf_out && *out_format != MeshFormat::kDraco && !draco_in) {
    std::cerr << "meshsmooth: --edgebreaker reorders the result's vertices; it applies to a .drc or glTF output (or a "
                 ".drc input): give -o FILE.drc, or leave --edgebreaker out\n";
    return kExitUsage;
  }
  // Before the upload: a typo in the output's folder must not cost the job.
  if (absl::Status s = CheckOutputPath(o.output); !s.ok()) {
    std::cerr << "meshsmooth: " << s.message() << "\n";
    return kExitUsage;
  }
  if (o.ridges && (gltf_out || (*out_format != MeshFormat::kPly && *out_format != MeshFormat::kObj &&
                                *out_format != MeshFormat::kDraco))) {
    std::cerr << "meshsmooth: warning: --ridges labels are kept only in .ply and .obj (vertex colours) and .drc "
                 "(attributes) output; the summary still counts them\n";
  }
  const bool in_memory = RunsInMemory(o, c, *out_format);
  // The attributes go to the service only for a .drc output, which is written as it comes back.
  absl::StatusOr<Upload> upload =
      PrepareUpload(o.input, *out_format == MeshFormat::kDraco, o.gltf_draco, o.strength, in_memory);
  if (!upload.ok()) return Fail("", upload.status());
  for (const std::string& w : upload->warnings) std::cerr << "meshsmooth: warning: " << w << "\n";
  const v1::JobSpec spec = SpecFrom(o);
  ProgressPrinter progress(o.quiet || o.json);
  JobRun run = in_memory ? RunInMemory(spec, *upload, c, progress)
                         : RunThroughService(spec, *upload, c, o.quiet || o.json, progress);
  progress.Done();
  if (run.interrupted) {
    std::cerr << "meshsmooth: interrupted; the job was cancelled\n";
    return kExitInterrupted;
  }
  if (!run.status.ok()) return Fail(run.prefix, run.status);
  std::vector<std::string> dropped = upload->dropped;
  DracoOptions draco;
  draco.quantization_bits = o.quantization_bits;
  draco.method = o.edgebreaker ? DracoMethod::kEdgebreaker : DracoMethod::kSequential;
  const absl::Status written =
      in_memory
          ? WriteResultPoints(*upload, std::move(run.local.points), run.local.labels, o.output, o.ridges, &dropped)
          : WriteResult(*upload, run.result, o.output, o.ridges, &dropped, o.gltf_draco, draco);
  if (!written.ok()) return Fail("", written);
  for (const std::string& w : run.summary.warnings()) std::cerr << "meshsmooth: warning: " << w << "\n";
  // Everything not carried from the input to the output, in one line.
  if (!dropped.empty()) std::cerr << "meshsmooth: warning: not kept: " << absl::StrJoin(dropped, "; ") << "\n";
  if (o.json) {
    // The JSON lists every warning, the CLI's own (about the input and the output) first.
    v1::Summary summary;
    for (const std::string& w : upload->warnings) summary.add_warnings(w);
    for (const std::string& d : dropped) summary.add_warnings(absl::StrCat("not kept: ", d));
    summary.MergeFrom(run.summary);
    std::printf("%s", ToJson(summary).c_str());
  } else if (!o.quiet) {
    PrintSummary(run.summary);
    std::printf("wrote %s\n", o.output.c_str());
  }
  return 0;
}

int RunFlows(const ConnectionOptions& c, bool json) {
  std::unique_ptr<server::Server> embedded;
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = Connect(c, embedded);
  if (!channel.ok()) {
    std::cerr << "meshsmooth: " << channel.status().message() << "\n";
    return kExitFailure;
  }
  auto stub = v1::MeshSmoother::NewStub(*channel);
  grpc::ClientContext ctx;
  if (absl::Status s = PrepareContext(c, ctx, CallDeadline(c)); !s.ok()) {
    std::cerr << "meshsmooth: " << s.message() << "\n";
    return kExitFailure;
  }
  v1::ListFlowsResponse flows;
  const grpc::Status s = stub->ListFlows(&ctx, v1::ListFlowsRequest(), &flows);
  if (!s.ok()) return Fail("", WithConnectionHint(FromGrpc(s), c));
  if (json) {
    std::printf("%s", ToJson(flows).c_str());
  } else {
    PrintFlows(flows);
  }
  return 0;
}

int RunInfo(const std::string& input) {
  absl::StatusOr<Mesh> mesh = LoadInput(input);
  if (!mesh.ok()) {
    std::cerr << "meshsmooth: " << mesh.status().message() << "\n";
    return kExitFailure;
  }
  ValidationReport report;
  const Topology topo = BuildTopology(*mesh, &report);
  std::cout << "# " << input << "\n\n## validation\n"
            << FormatReport(report) << "\n## metrics\n"
            << FormatMetrics(ComputeMetrics(*mesh, topo));
  return 0;
}

int RunRidges(const std::string& input, const std::string& output, const std::string& threshold) {
  absl::StatusOr<MeshFormat> format = FormatFromPath(output);
  if (!format.ok() || *format != MeshFormat::kPly) {
    std::cerr << "meshsmooth: ridges writes PLY (labels as vertex colours): give -o FILE.ply\n";
    return kExitUsage;
  }
  FeatureOptions options;
  if (threshold == "auto") {
    options.relative_threshold = kDefaultRelativeThreshold;
  } else if (!absl::SimpleAtod(threshold, &options.min_abs_curvature) || !std::isfinite(options.min_abs_curvature) ||
             options.min_abs_curvature < 0.0) {
    std::cerr << "meshsmooth: --threshold must be auto or a finite number >= 0, got '" << threshold << "'\n";
    return kExitUsage;
  }
  absl::StatusOr<Mesh> mesh = LoadInput(input);
  if (!mesh.ok()) {
    std::cerr << "meshsmooth: " << mesh.status().message() << "\n";
    return kExitFailure;
  }
  const Topology topo = BuildTopology(*mesh);
  const Features features = DetectFeatures(*mesh, topo, options);
  mesh->colors = FeatureColors(features.labels);
  if (absl::Status s = WriteMesh(output, *mesh); !s.ok()) {
    std::cerr << "meshsmooth: " << s.message() << "\n";
    return kExitFailure;
  }
  std::printf(
      "%lld ridge and %lld ravine vertices of %lld classified (%d vertices; |curvature| threshold %g); wrote %s\n",
      static_cast<long long>(features.ridges), static_cast<long long>(features.ravines),
      static_cast<long long>(features.classified), mesh->num_vertices(), features.threshold, output.c_str());
  return 0;
}

int RunRender(const RenderCommand& r) {
  RenderOptions options;
  absl::StatusOr<View> view = ParseView(r.view);
  int w = 0, h = 0;
  char tail = 0;
  if (!view.ok()) {
    std::cerr << "meshsmooth: --view: " << view.status().message() << "\n";
    return kExitUsage;
  }
  if (std::sscanf(r.size.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < kMinRenderSide || h < kMinRenderSide ||
      w > kMaxRenderSide || h > kMaxRenderSide) {
    std::cerr << "meshsmooth: --size must be WIDTHxHEIGHT with each side in " << kMinRenderSide << ".."
              << kMaxRenderSide << ", e.g. 800x600, got '" << r.size << "'\n";
    return kExitUsage;
  }
  options.view = *view;
  options.width = w;
  options.height = h;
  options.shading = r.shading == "flat" ? Shading::kFlat : Shading::kGouraud;
  if (absl::Status s = CheckStrengthOptions(r.strength); !s.ok()) {
    std::cerr << "meshsmooth: " << s.message() << "\n";
    return kExitUsage;
  }
  absl::StatusOr<Mesh> mesh = LoadInput(r.input);
  if (!mesh.ok()) {
    std::cerr << "meshsmooth: " << mesh.status().message() << "\n";
    return kExitFailure;
  }
  if (r.strength.any()) {
    absl::StatusOr<std::vector<float>> strength = VertexStrength(*mesh, r.strength);
    if (!strength.ok()) {
      std::cerr << "meshsmooth: " << strength.status().message() << "\n";
      return kExitFailure;
    }
    mesh->colors = StrengthColours(*strength);
  }
  absl::StatusOr<Image> image = Render(*mesh, options);
  if (!image.ok()) {
    std::cerr << "meshsmooth: " << image.status().message() << "\n";
    return kExitFailure;
  }
  if (absl::Status s = WritePng(r.output, *image); !s.ok()) {
    std::cerr << "meshsmooth: " << s.message() << "\n";
    return kExitFailure;
  }
  std::printf("wrote %s (%dx%d)\n", r.output.c_str(), image->width, image->height);
  return 0;
}

}  // namespace meshsmooth::client
