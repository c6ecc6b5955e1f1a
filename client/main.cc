// meshsmooth: the command-line client.
//
//   meshsmooth smooth IN -o OUT [--flow median] [--iterations N] [--step S] [flow options]
//                               [--server HOST:PORT]
//   meshsmooth flows [--server HOST:PORT]
//   meshsmooth info IN
//   meshsmooth ridges IN -o OUT.ply [--threshold K]      (locally, no smoothing)
//   meshsmooth render IN -o OUT.png [--view V] [--size WxH] [--shading flat|gouraud]
//
// Without --server, `smooth` and `flows` start the service in-process (the same code as
// meshsmoothd, over an in-process channel), so the CLI works with nothing else running.
//
// Exit codes: 0 success; 1 the job or the input failed; 2 bad command line; 3 the server
// could not be reached; 130 interrupted (Ctrl-C cancels the job on the server).
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <thread>

#include "CLI/CLI.hpp"
#include "absl/strings/str_cat.h"
#include "client/inputs.h"
#include "client/json.h"
#include "client/smooth_client.h"
#include "core/draco_codec.h"
#include "core/features/ridges.h"
#include "core/huge_pages.h"
#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/metrics.h"
#include "core/shutdown_signals.h"
#include "core/render/png.h"
#include "core/render/render.h"
#include "core/topology.h"
#include "grpcpp/grpcpp.h"
#include "server/server.h"

namespace meshsmooth::client {
namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;
constexpr int kExitUnavailable = 3;
constexpr int kExitInterrupted = 130;

struct ConnectionOptions {
  std::string server;      // empty = in-process
  std::string token_file;  // bearer token
  std::string tls_ca;      // PEM roots; enables TLS
  double timeout_seconds = 3600.0;
};

struct SmoothOptions {
  std::string input, output;
  std::string flow = "median";
  unsigned iterations = 20;
  double step = 0.0;
  std::string weights = "u0";
  double mu = 0.0, pass_band = 0.0, tangential_weight = -1.0, epsilon = 0.0;
  std::string adaptive = "none";
  double threshold = 0.0;
  unsigned recompute_every = 10;
  std::string boundary = "fixed";
  double tolerance = 0.0;
  unsigned quantization_bits = 0;
  bool edgebreaker = false;
  bool quiet = false, json = false;
  bool ridges = false;
  double ridge_threshold = 0.0;
};

// The channel to a server, or to an in-process one started here (kept alive in `embedded`).
absl::StatusOr<std::shared_ptr<grpc::Channel>> Connect(const ConnectionOptions& c,
                                                       std::unique_ptr<server::Server>& embedded) {
  if (c.server.empty()) {
    server::ServerOptions o;
    o.log_jobs = false;
    o.workers = 1;
    absl::StatusOr<std::unique_ptr<server::Server>> s = server::Server::Start(o, /*listen=*/false);
    if (!s.ok()) return s.status();
    embedded = std::move(*s);
    return embedded->InProcessChannel();
  }
  std::shared_ptr<grpc::ChannelCredentials> creds = grpc::InsecureChannelCredentials();
  if (!c.tls_ca.empty()) {
    absl::StatusOr<std::string> ca = ReadFileBytes(c.tls_ca);
    if (!ca.ok()) return absl::InvalidArgumentError(absl::StrCat("the CA file: ", ca.status().message()));
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = std::move(*ca);
    creds = grpc::SslCredentials(ssl);
  }
  return grpc::CreateChannel(c.server, creds);
}

absl::Status PrepareContext(const ConnectionOptions& c, grpc::ClientContext& ctx) {
  ctx.set_deadline(std::chrono::system_clock::now() +
                   std::chrono::milliseconds(static_cast<int64_t>(c.timeout_seconds * 1000)));
  if (!c.token_file.empty()) {
    absl::StatusOr<std::string> token = ReadTokenFile(c.token_file);
    if (!token.ok()) return token.status();
    ctx.AddMetadata("authorization", "Bearer " + *token);
  }
  return absl::OkStatus();
}

int ExitCodeFor(const absl::Status& s) {
  if (s.code() == absl::StatusCode::kUnavailable) return kExitUnavailable;
  return kExitFailure;
}

// Ctrl-C: SIGINT/SIGTERM are blocked in every thread and waited for here; the first one
// cancels the call on the server.
class InterruptWatcher {
 public:
  explicit InterruptWatcher(grpc::ClientContext* ctx) : ctx_(ctx) {
    thread_ = std::thread([this] {
      while (!stop_.load()) {
        if (WaitForShutdownSignal(std::chrono::milliseconds(100)) != 0) {
          interrupted_.store(true);
          ctx_->TryCancel();
          return;
        }
      }
    });
  }
  ~InterruptWatcher() {
    stop_.store(true);
    thread_.join();
  }
  bool interrupted() const { return interrupted_.load(); }

 private:
  grpc::ClientContext* ctx_;
  std::atomic<bool> stop_{false}, interrupted_{false};
  std::thread thread_;
};

// Progress on stderr: a bar on a terminal, plain lines otherwise.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}
  void operator()(const v1::Progress& p) {
    if (quiet_) return;
    const double frac = p.total() > 0 ? static_cast<double>(p.iteration()) / p.total() : 1.0;
    const double eta = frac > 0 ? p.elapsed_seconds() * (1.0 - frac) / frac : 0.0;
    if (tty_) {
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(frac * kWidth);
      std::fprintf(stderr, "\r[%s%s] %u/%u  max move %.3g  mean %.3g  ETA %.1fs ", std::string(filled, '#').c_str(),
                   std::string(kWidth - filled, '.').c_str(), p.iteration(), p.total(), p.max_displacement(),
                   p.mean_displacement(), eta);
      bar_shown_ = true;
    } else {
      std::fprintf(stderr, "iteration %u/%u max move %.6g mean %.6g moved %.1f%% elapsed %.2fs\n", p.iteration(),
                   p.total(), p.max_displacement(), p.mean_displacement(), 100.0 * p.moved_share(),
                   p.elapsed_seconds());
    }
  }
  void Done() {
    if (bar_shown_) std::fprintf(stderr, "\n");
  }

 private:
  bool quiet_, tty_, bar_shown_ = false;
};

void PrintSummary(const v1::Summary& s) {
  const v1::MeshMetrics &a = s.before(), &b = s.after();
  const v1::EffectiveParameters& p = s.parameters();
  std::printf("job %s: %s, %u of %u iterations (stopped by %s), step %g (effective %g)\n", s.job_id().c_str(),
              p.flow().c_str(), p.iterations_run(), p.iterations_requested(), p.stop_reason().c_str(), p.step(),
              p.effective_step());
  std::printf("%-28s %14s %14s\n", "", "before", "after");
  std::printf("%-28s %14.6g %14.6g\n", "area", a.area(), b.area());
  std::printf("%-28s %14.6g %14.6g\n", "signed volume", a.signed_volume(), b.signed_volume());
  std::printf("%-28s %14.6g %14.6g\n", "edge length mean", a.edge_length_mean(), b.edge_length_mean());
  std::printf("%-28s %14.4f %14.4f\n", "edge length CV", a.edge_length_cv(), b.edge_length_cv());
  std::printf("%-28s %14.2f %14.2f\n", "min angle (deg)", a.min_angle_deg(), b.min_angle_deg());
  std::printf("%-28s %13.2f%% %13.2f%%\n", "angles below 10 deg", 100 * a.share_angles_below_10deg(),
              100 * b.share_angles_below_10deg());
  std::printf("displacement RMS %.6g, max %.6g; flipped normals %lld\n", s.rms_displacement(), s.max_displacement(),
              static_cast<long long>(s.flipped_normals()));
  if (s.has_features()) {
    std::printf("features: %lld ridge and %lld ravine vertices of %lld classified (%.3fs)\n",
                static_cast<long long>(s.features().ridge_vertices()),
                static_cast<long long>(s.features().ravine_vertices()),
                static_cast<long long>(s.features().classified_vertices()), s.features().detect_seconds());
  }
  const v1::Timings& t = s.timings();
  std::printf("time: decode %.3fs, queue %.3fs, smooth %.3fs, encode %.3fs, total %.3fs; result %llu bytes\n",
              t.decode_seconds(), t.queue_seconds(), t.smooth_seconds(), t.encode_seconds(), t.total_seconds(),
              static_cast<unsigned long long>(s.result_bytes()));
}

absl::StatusOr<v1::JobSpec> SpecFrom(const SmoothOptions& o) {
  v1::JobSpec spec;
  spec.set_flow(o.flow);
  spec.set_iterations(o.iterations);
  spec.set_step(o.step);
  spec.set_weights(o.weights == "u1" ? v1::UMBRELLA_WEIGHTS_INVERSE_DISTANCE : v1::UMBRELLA_WEIGHTS_UNIFORM);
  if (o.mu > 0) spec.set_taubin_mu(o.mu);
  if (o.pass_band > 0) spec.set_taubin_pass_band(o.pass_band);
  if (o.tangential_weight >= 0) spec.set_tangential_weight(o.tangential_weight);
  if (o.epsilon > 0) spec.set_epsilon(o.epsilon);
  static const std::map<std::string, v1::AdaptiveMode> kModes = {{"none", v1::ADAPTIVE_MODE_NONE},
                                                                 {"constant", v1::ADAPTIVE_MODE_CONSTANT},
                                                                 {"ring1", v1::ADAPTIVE_MODE_RING1},
                                                                 {"ring2", v1::ADAPTIVE_MODE_RING2}};
  spec.mutable_adaptive()->set_mode(kModes.at(o.adaptive));
  spec.mutable_adaptive()->set_threshold(o.threshold);
  spec.mutable_adaptive()->set_recompute_every(o.recompute_every);
  spec.set_boundary(o.boundary == "curve" ? v1::BOUNDARY_MODE_CURVE : v1::BOUNDARY_MODE_FIXED);
  spec.set_tolerance(o.tolerance);
  spec.mutable_output()->set_quantization_bits(o.quantization_bits);
  spec.mutable_output()->set_edgebreaker(o.edgebreaker);
  if (o.ridges) {
    spec.mutable_features()->set_enabled(true);
    spec.mutable_features()->set_min_abs_curvature(o.ridge_threshold);
  }
  return spec;
}

int RunSmooth(const SmoothOptions& o, const ConnectionOptions& c) {
  auto err = [](const std::string& what, const absl::Status& s) {
    std::cerr << "meshsmooth: " << what << s.message() << "\n";
    return ExitCodeFor(s);
  };
  absl::StatusOr<MeshFormat> out_format = FormatFromPath(o.output);
  if (!out_format.ok()) return err("", out_format.status());

  // Draco input goes as it is (all its attributes travel along); anything else is encoded
  // losslessly and sequentially, so vertex i of the result is vertex i of the input.
  if (o.ridges && *out_format != MeshFormat::kPly && *out_format != MeshFormat::kDraco) {
    std::cerr << "meshsmooth: warning: --ridges labels are kept only in .ply (vertex colours) and .drc "
                 "(attributes) output; the summary still counts them\n";
  }
  std::string draco;
  std::vector<Rgb> input_colors;  // carried to PLY output (vertex i of the result is vertex i)
  const bool drc_input = FormatFromPath(o.input).ok() && *FormatFromPath(o.input) == MeshFormat::kDraco;
  if (drc_input) {
    absl::StatusOr<std::string> bytes = ReadFileBytes(o.input);
    if (!bytes.ok()) return err("", bytes.status());
    draco = std::move(*bytes);
  } else {
    absl::StatusOr<Mesh> mesh = LoadInput(o.input);
    if (!mesh.ok()) return err("", mesh.status());
    const ValidationReport r = Validate(*mesh);
    if (r.faces_out_of_range > 0) {
      std::cerr << "meshsmooth: warning: " << r.faces_out_of_range
                << " faces reference vertices that do not exist; they cannot be sent and are left out\n";
    }
    absl::StatusOr<std::string> bytes = EncodeDraco(*mesh);
    if (!bytes.ok()) return err("", bytes.status());
    draco = std::move(*bytes);
    input_colors = std::move(mesh->colors);
  }
  absl::StatusOr<v1::JobSpec> spec = SpecFrom(o);
  if (!spec.ok()) return err("", spec.status());

  std::unique_ptr<server::Server> embedded;
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = Connect(c, embedded);
  if (!channel.ok()) return err("", channel.status());
  auto stub = v1::MeshSmoother::NewStub(*channel);
  grpc::ClientContext ctx;
  if (absl::Status s = PrepareContext(c, ctx); !s.ok()) return err("", s);
  ProgressPrinter progress(o.quiet || o.json);
  absl::StatusOr<SmoothOutcome> outcome;
  bool interrupted = false;
  {
    InterruptWatcher watcher(&ctx);
    outcome = CallSmooth(*stub, ctx, *spec, draco, std::ref(progress));
    interrupted = watcher.interrupted();
  }
  progress.Done();
  if (interrupted) {
    std::cerr << "meshsmooth: interrupted; the job was cancelled\n";
    return kExitInterrupted;
  }
  if (!outcome.ok()) return err(std::string(absl::StatusCodeToString(outcome.status().code())) + ": ", outcome.status());

  if (*out_format == MeshFormat::kDraco) {
    if (absl::Status s = WriteFileBytes(o.output, outcome->result); !s.ok()) return err("", s);
  } else {
    absl::StatusOr<Mesh> result = DecodeDraco(outcome->result);
    if (!result.ok()) return err("the result: ", result.status());
    if (o.ridges) {
      absl::StatusOr<std::vector<float>> labels = DecodeDracoAttribute(outcome->result, kFeatureLabelAttribute);
      if (!labels.ok()) return err("the result: ", labels.status());
      result->colors = FeatureColors(std::vector<uint8_t>(labels->begin(), labels->end()));
    } else if (input_colors.size() == result->positions.size()) {
      result->colors = std::move(input_colors);
    }
    if (absl::Status s = WriteMesh(o.output, *result); !s.ok()) return err("", s);
  }
  if (o.json) {
    std::printf("%s", ToJson(outcome->summary).c_str());
  } else if (!o.quiet) {
    PrintSummary(outcome->summary);
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
  if (absl::Status s = PrepareContext(c, ctx); !s.ok()) {
    std::cerr << "meshsmooth: " << s.message() << "\n";
    return kExitFailure;
  }
  v1::ListFlowsResponse flows;
  const grpc::Status s = stub->ListFlows(&ctx, v1::ListFlowsRequest(), &flows);
  if (!s.ok()) {
    std::cerr << "meshsmooth: " << s.error_message() << "\n";
    return ExitCodeFor(FromGrpc(s));
  }
  if (json) {
    std::printf("%s", ToJson(flows).c_str());
    return 0;
  }
  auto range = [](const v1::ParameterInfo& p) {
    if (p.choices_size() > 0) {
      std::string list;
      for (const auto& x : p.choices()) list += (list.empty() ? "" : " | ") + x;
      return list;
    }
    std::ostringstream r;
    r << "default " << p.default_value() << ", range " << (p.min_exclusive() ? "(" : "[") << p.min_value() << ", "
      << p.max_value() << (p.max_exclusive() ? ")" : "]");
    return r.str();
  };
  for (const v1::FlowInfo& f : flows.flows()) {
    std::printf("%s  (paper: %s)\n  %s\n", f.name().c_str(), f.equations().c_str(), f.description().c_str());
    for (const v1::ParameterInfo& p : f.parameters()) {
      std::printf("    %-18s %s; %s\n", p.name().c_str(), p.description().c_str(), range(p).c_str());
    }
  }
  std::printf("every flow:\n");
  for (const v1::ParameterInfo& p : flows.common_parameters()) {
    std::printf("    %-24s %s; %s\n", p.name().c_str(), p.description().c_str(), range(p).c_str());
  }
  std::printf("this server allows at most %u iterations\n", flows.max_iterations());
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

// Ridges and ravines of a mesh as it is (no smoothing), written as PLY vertex colours.
int RunRidges(const std::string& input, const std::string& output, double threshold) {
  absl::StatusOr<MeshFormat> format = FormatFromPath(output);
  if (!format.ok() || *format != MeshFormat::kPly) {
    std::cerr << "meshsmooth: ridges writes PLY (labels as vertex colours): give -o FILE.ply\n";
    return kExitUsage;
  }
  if (!std::isfinite(threshold) || threshold < 0.0) {
    std::cerr << "meshsmooth: --threshold must be finite and >= 0\n";
    return kExitUsage;
  }
  absl::StatusOr<Mesh> mesh = LoadInput(input);
  if (!mesh.ok()) {
    std::cerr << "meshsmooth: " << mesh.status().message() << "\n";
    return kExitFailure;
  }
  const Topology topo = BuildTopology(*mesh);
  FeatureOptions options;
  options.min_abs_curvature = threshold;
  const Features features = DetectFeatures(*mesh, topo, options);
  mesh->colors = FeatureColors(features.labels);
  if (absl::Status s = WriteMesh(output, *mesh); !s.ok()) {
    std::cerr << "meshsmooth: " << s.message() << "\n";
    return kExitFailure;
  }
  std::printf("%lld ridge and %lld ravine vertices of %lld classified (%d vertices); wrote %s\n",
              static_cast<long long>(features.ridges), static_cast<long long>(features.ravines),
              static_cast<long long>(features.classified), mesh->num_vertices(), output.c_str());
  return 0;
}

struct RenderCommand {
  std::string input = "builtin:noisy-sphere", output, view = "30,20", size = "800x800", shading = "gouraud";
};

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
  absl::StatusOr<Mesh> mesh = LoadInput(r.input);
  if (!mesh.ok()) {
    std::cerr << "meshsmooth: " << mesh.status().message() << "\n";
    return kExitFailure;
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

void AddConnectionOptions(CLI::App* app, ConnectionOptions& c) {
  app->add_option("--server", c.server, "HOST:PORT of a meshsmoothd; default: an in-process server");
  app->add_option("--token-file", c.token_file, "file with the bearer token the server expects");
  app->add_option("--tls-ca", c.tls_ca, "PEM CA certificates: connect with TLS");
  app->add_option("--timeout", c.timeout_seconds, "deadline of the call, seconds")->capture_default_str();
}

}  // namespace
}  // namespace meshsmooth::client

int main(int argc, char** argv) {
  meshsmooth::UseHugePagesForLargeBuffers(argv);  // first: may re-execute the program
  using namespace meshsmooth::client;
  // Before any thread exists: Ctrl-C is handled by InterruptWatcher, not by a handler.
  meshsmooth::BlockShutdownSignals();

  CLI::App app{"meshsmooth: smooth noisy triangle meshes while making them more regular"};
  app.require_subcommand(1);
  std::string footer =
      "Exit codes: 0 success, 1 the job or the input failed, 2 bad command line, 3 server unreachable, "
      "130 interrupted.\nBuilt-in inputs (use as builtin:NAME):";
  for (const auto& [name, what] : BuiltinInputs()) footer += "\n  " + name + ": " + what;
  app.footer(footer);

  SmoothOptions so;
  ConnectionOptions sc;
  CLI::App* smooth = app.add_subcommand("smooth", "Smooth a mesh through meshsmoothd (or an in-process server)");
  smooth->add_option("input", so.input, "mesh file (.obj .ply .off .stl .drc) or builtin:NAME")->required();
  smooth->add_option("-o,--output", so.output, "output file; its extension picks the format")->required();
  smooth->add_option("--flow", so.flow, "laplacian | taubin | bilaplacian | mcf | mcf_tangential | median")
      ->capture_default_str()
      ->check(CLI::IsMember({"laplacian", "taubin", "bilaplacian", "mcf", "mcf_tangential", "median"}));
  smooth->add_option("--iterations", so.iterations, "number of iterations")->capture_default_str();
  smooth->add_option("--step", so.step,
                     "lambda: dimensionless for laplacian/taubin/bilaplacian, relative to the squared mean edge "
                     "length for mcf/mcf_tangential/median; 0 = the flow's default (see `meshsmooth flows`)")
      ->capture_default_str();
  smooth->add_option("--weights", so.weights, "umbrella weights of laplacian/taubin: u0 uniform, u1 inverse distance")
      ->capture_default_str()->check(CLI::IsMember({"u0", "u1"}));
  smooth->add_option("--mu", so.mu, "taubin: mu (> step); 0 = from --pass-band")->capture_default_str();
  smooth->add_option("--pass-band", so.pass_band, "taubin: k_PB = 1/lambda - 1/mu; 0 = 0.1")->capture_default_str();
  smooth->add_option("--tangential-weight", so.tangential_weight, "mcf_tangential: C; negative = default 5")
      ->capture_default_str();
  smooth->add_option("--epsilon", so.epsilon, "median: epsilon in (0, 1); 0 = default 0.1")->capture_default_str();
  smooth->add_option("--adaptive", so.adaptive, "eq. (14): none | constant | ring1 | ring2")
      ->capture_default_str()->check(CLI::IsMember({"none", "constant", "ring1", "ring2"}));
  smooth->add_option("--threshold", so.threshold, "T for --adaptive constant")->capture_default_str();
  smooth->add_option("--recompute-every", so.recompute_every, "T(P) recomputed every K iterations")
      ->capture_default_str();
  smooth->add_option("--boundary", so.boundary, "fixed | curve (smooth boundary loops as curves)")
      ->capture_default_str()->check(CLI::IsMember({"fixed", "curve"}));
  smooth->add_option("--tolerance", so.tolerance, "stop when the largest move < tolerance x mean edge; 0 = off")
      ->capture_default_str();
  smooth->add_option("--quantization-bits", so.quantization_bits,
                     "result positions: 0 = lossless (exact float32), 1..30 = quantized")
      ->capture_default_str()->check(CLI::Range(0, 30));
  smooth->add_flag("--edgebreaker", so.edgebreaker, "encode the result with Edgebreaker (reorders vertices)");
  smooth->add_flag("-q,--quiet", so.quiet, "print nothing but errors");
  smooth->add_flag("--json", so.json, "print the job summary as JSON on stdout (no progress)");
  smooth->add_flag("--ridges", so.ridges,
                   "detect ridge and ravine vertices after smoothing (paper Section 5); PLY output gets them as "
                   "vertex colours (ridges black, ravines white, others grey), .drc output as attributes");
  smooth->add_option("--ridge-threshold", so.ridge_threshold,
                     "with --ridges: ignore features with |curvature| at or below this (1/mesh units)")
      ->capture_default_str();
  AddConnectionOptions(smooth, sc);

  ConnectionOptions fc;
  bool flows_json = false;
  CLI::App* flows = app.add_subcommand("flows", "List the flows with their parameters, defaults and ranges");
  flows->add_flag("--json", flows_json, "print the ListFlows response as JSON");
  AddConnectionOptions(flows, fc);

  std::string info_input = "builtin:noisy-sphere";
  CLI::App* info = app.add_subcommand("info", "Print a mesh's validation report and metrics (locally)");
  info->add_option("input", info_input, "mesh file (.obj .ply .off .stl .drc) or builtin:NAME")->capture_default_str();

  std::string ridges_input, ridges_output;
  double ridges_threshold = 0.0;
  CLI::App* ridges = app.add_subcommand(
      "ridges", "Detect ridge (black) and ravine (white) vertices of a mesh as it is, locally, into a PLY");
  ridges->add_option("input", ridges_input, "mesh file or builtin:NAME")->required();
  ridges->add_option("-o,--output", ridges_output, "output .ply (labels as vertex colours)")->required();
  ridges->add_option("--threshold", ridges_threshold, "ignore features with |curvature| at or below this (1/mesh units)")
      ->capture_default_str();

  RenderCommand rc;
  CLI::App* render = app.add_subcommand("render", "Render a mesh to a PNG picture (locally; vertex colours shown)");
  render->add_option("input", rc.input, "mesh file or builtin:NAME")->capture_default_str();
  render->add_option("-o,--output", rc.output, "output .png")->required();
  render->add_option("--view", rc.view,
                     "front | back | left | right | top | bottom | iso, or AZIMUTH,ELEVATION in degrees")
      ->capture_default_str();
  render->add_option("--size", rc.size, "WIDTHxHEIGHT in pixels (16..8192 each)")->capture_default_str();
  render->add_option("--shading", rc.shading, "gouraud (smooth) | flat (one shade per face)")
      ->check(CLI::IsMember({"gouraud", "flat"}))
      ->capture_default_str();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : kExitUsage;
  }
  if (smooth->parsed()) return RunSmooth(so, sc);
  if (flows->parsed()) return RunFlows(fc, flows_json);
  if (info->parsed()) return RunInfo(info_input);
  if (ridges->parsed()) return RunRidges(ridges_input, ridges_output, ridges_threshold);
  if (render->parsed()) return RunRender(rc);
  return kExitUsage;
}
