#include "client/commands.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/inputs.h"
#include "client/json.h"
#include "client/report.h"
#include "client/smooth_client.h"
#include "client/smooth_file.h"
#include "core/features/ridges.h"
#include "core/io/mesh_io.h"
#include "core/measure/metrics.h"
#include "core/render/png.h"
#include "core/render/render.h"
#include "core/topology.h"

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

}  // namespace

int RunSmooth(const SmoothOptions& o, const ConnectionOptions& c) {
  std::vector<std::string> warnings;
  if (absl::Status s = CheckInputOutput(o, warnings); !s.ok()) {
    std::cerr << "meshsmooth: " << s.message() << "\n";
    return kExitUsage;
  }
  for (const std::string& w : warnings) std::cerr << "meshsmooth: warning: " << w << "\n";
  ProgressPrinter progress(o.quiet || o.json);
  FileHooks hooks;
  hooks.progress = std::ref(progress);
  hooks.upload_warnings = [](const std::vector<std::string>& ws) {
    for (const std::string& w : ws) std::cerr << "meshsmooth: warning: " << w << "\n";
  };
  hooks.job_done = [&progress] { progress.Done(); };
  hooks.retry = [quiet = o.quiet || o.json](int retry, const absl::Status& s, std::chrono::milliseconds wait) {
    if (!quiet) PrintRetry("", retry, s, wait);
  };
  hooks.watch_interrupt = true;
  ServiceLink service(c);
  JobCancels cancels;
  const FileOutcome f = SmoothFile(o, service, cancels, hooks);
  if (f.exit_code != 0) {
    std::cerr << "meshsmooth: " << f.error << "\n";
    return f.exit_code;
  }
  for (const std::string& w : f.summary.warnings()) std::cerr << "meshsmooth: warning: " << w << "\n";
  // Everything not carried from the input to the output, in one line.
  if (!f.dropped.empty()) std::cerr << "meshsmooth: warning: not kept: " << absl::StrJoin(f.dropped, "; ") << "\n";
  if (o.json) {
    // The JSON lists every warning, the CLI's own (about the input and the output) first.
    std::printf("%s", ToJson(SummaryWithWarnings(f)).c_str());
  } else if (!o.quiet) {
    PrintSummary(f.summary);
    if (!f.upload_note.empty()) std::printf("%s\n", f.upload_note.c_str());
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
