// meshsmooth: the command-line client.
//
//   meshsmooth smooth IN -o OUT [--flow auto|NAME] [--iterations auto|N] [--step S] [flow options]
//                               [--server TARGET] [--retries N] [--job-id ID]
//   meshsmooth smooth IN... | DIR | 'GLOB' | --batch LIST  -o OUTDIR [--format EXT] [--jobs N] [...]
//   meshsmooth flows [--server TARGET]
//   meshsmooth info IN
//   meshsmooth ridges IN -o OUT.ply [--threshold K]      (locally, no smoothing)
//   meshsmooth enhance IN -o OUT [--gain G] [--detail D|Dh] [--smooth-first] [--server TARGET]
//   meshsmooth render IN -o OUT.png [--view V] [--size WxH] [--shading flat|gouraud]
//
// Without --server, `smooth`, `enhance` and `flows` start the service in-process (the same code as
// meshsmoothd, over an in-process channel), so the CLI works with nothing else running.
// This file is the command line; the commands are in commands.cc. The flows' names, defaults
// and which flow takes which option come from the flow table (DescribeFlows()).
//
// Exit codes: 0 success; 1 the job or the input failed (a batch: any file); 2 bad command line; 3 the server
// could not be reached; 130 interrupted (Ctrl-C cancels the job on the server).
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "CLI/CLI.hpp"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "base/huge_pages.h"
#include "base/kernel_environment.h"
#include "base/shutdown_signals.h"
#include "client/batch.h"
#include "client/batch_plan.h"
#include "client/commands.h"
#include "client/inputs.h"
#include "client/job_commands.h"
#include "client/transfer.h"
#include "client/upload_quantization.h"
#include "core/flows/catalogue.h"
#include "core/flows/flow.h"
#include "core/io/draco_codec.h"
#include "core/io/mesh_io.h"
#include "core/job/enhance.h"
#include "grpc/support/log.h"

namespace meshsmooth::client {
namespace {

// gRPC's own log lines (a failed TLS handshake, say) are not for the CLI's user: the call's
// status says what failed, with a hint (WithConnectionHint). GRPC_VERBOSITY brings them back.
void DiscardGrpcLog(gpr_log_func_args*) {}

// An input that names a built-in shape must name one that exists.
CLI::Validator KnownInput() {
  return CLI::Validator(
      [](std::string& input) -> std::string {
        if (!absl::StartsWith(input, "builtin:")) return "";
        std::vector<std::string> names;
        for (const auto& [name, what] : BuiltinInputs()) {
          if (input == "builtin:" + name) return "";
          names.push_back("builtin:" + name);
        }
        return absl::StrCat("unknown built-in input '", input, "' (known: ", absl::StrJoin(names, ", "), ")");
      },
      "", "builtin");
}

// The output's extension must name a format the CLI writes.
CLI::Validator KnownOutputFormat() {
  return CLI::Validator(
      [](std::string& output) -> std::string {
        if (IsGltfPath(output) || FormatFromPath(output).ok()) return "";
        return absl::StrCat("'", output, "': unknown output format (use .obj, .ply, .off, .stl, .drc, .glb or .gltf)");
      },
      "", "format");
}

// --timeout: a number of seconds above 0 (a deadline in the past fails every call).
CLI::Validator PositiveSeconds() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        double seconds = 0.0;
        if (absl::SimpleAtod(value, &seconds) && seconds > 0.0 && seconds <= 1e9) return "";
        return absl::StrCat("must be a number of seconds above 0 (at most 1e9), got '", value, "'");
      },
      "SECONDS > 0", "seconds");
}

// "laplacian/taubin": the flows that take the JobSpec parameter `name`.
std::string FlowsTaking(const std::vector<FlowInfo>& flows, std::string_view name) {
  std::vector<std::string> names;
  for (const FlowInfo& f : flows) {
    for (const ParameterInfo& p : f.parameters) {
      if (p.name == name) names.push_back(f.name);
    }
  }
  return absl::StrJoin(names, "/");
}

// The default of the parameter `name` (the same for every flow that takes it).
double DefaultOf(const std::vector<FlowInfo>& flows, std::string_view name) {
  for (const FlowInfo& f : flows) {
    for (const ParameterInfo& p : f.parameters) {
      if (p.name == name) return p.default_value;
    }
  }
  return 0.0;
}

// --step's help: the flows grouped by their step's unit, in table order, e.g. "dimensionless
// for laplacian/taubin/bilaplacian, relative to the squared mean edge length for mcf/...".
std::string StepUnits(const std::vector<FlowInfo>& flows) {
  std::vector<std::pair<std::string, std::vector<std::string>>> units;  // unit -> flows
  for (const FlowInfo& f : flows) {
    // The step is each flow's first parameter; its description is "lambda, UNIT" or "lambda UNIT".
    std::string_view unit = f.parameters.front().description;
    if (unit.substr(0, 6) == "lambda") unit.remove_prefix(6);
    if (unit.substr(0, 1) == ",") unit.remove_prefix(1);
    if (unit.substr(0, 1) == " ") unit.remove_prefix(1);
    auto it = std::find_if(units.begin(), units.end(), [&](const auto& u) { return u.first == unit; });
    if (it == units.end()) it = units.insert(units.end(), {std::string(unit), {}});
    it->second.push_back(f.name);
  }
  std::vector<std::string> parts;
  for (const auto& [unit, names] : units) parts.push_back(absl::StrCat(unit, " for ", absl::StrJoin(names, "/")));
  return absl::StrJoin(parts, ", ");
}

// The per-vertex strength flags (client/strength.h), on `smooth` and on `render`.
void AddStrengthOptions(CLI::App* app, StrengthOptions& st) {
  app->add_option("--weight", st.weight,
                  "per-vertex strength from a PLY vertex property: PROP (values in [0, 1]) or PROP:LO,HI (LO -> 0, "
                  "HI -> 1, clamped), e.g. --weight quality:0,255. 0 = the vertex does not move, 1 = the flow as "
                  "it is, between = its moves scaled; combined with --region and --fixed by product");
  app->add_option("--fixed", st.fixed,
                  "a file of vertex indices (0-based, as the input file numbers them; separated by spaces, commas "
                  "or lines; # starts a comment) held fixed: strength 0");
  app->add_option("--region", st.region,
                  "box:x0,y0,z0,x1,y1,z1 (two opposite corners) or sphere:cx,cy,cz,r, in the input's coordinates: "
                  "strength 1 inside, 0 outside");
  app->add_flag("--outside", st.outside, "with --region: strength 0 inside the region, 1 outside");
  app->add_option("--falloff", st.falloff,
                  "with --region: over this distance (mesh units) outside the region's edge the strength goes "
                  "smoothly (smoothstep) from the region's value to the other one; 0 = a sharp edge")
      ->capture_default_str();
}

void AddSmoothOptions(CLI::App* smooth, SmoothOptions& so, BatchOptions& batch) {
  const std::vector<FlowInfo> flows = DescribeFlows();
  smooth
      ->add_option("input", batch.inputs,
                   "mesh file (.obj .ply .off .stl .drc), glTF scene (.glb .gltf: every triangle primitive smoothed, "
                   "the rest of the scene kept; the output must be a scene too) or builtin:NAME. Several inputs, a "
                   "folder (its mesh files) or a quoted glob pattern ('scans/*.ply') make a batch: see --batch")
      ->check(KnownInput());
  smooth
      ->add_option("-o,--output", so.output,
                   "output file (a batch: its output folder, made when missing), its folder and format checked "
                   "before the upload; its extension picks the format "
                   "(.obj .ply .off .stl .drc, or .glb .gltf: a scene of one node, translated to a georeferenced "
                   "mesh's local origin). Texture coordinates (UV seams kept), colours and "
                   "PLY vertex properties come back where the format holds them, normals recomputed from the "
                   "smoothed positions; an .obj keeps its mtllib/usemtl/g/o/s lines, each mtllib rewritten as the "
                   "path from the output's folder to the input's .mtl, so materials and textures (named in the .mtl, "
                   "relative to it) resolve without copying. Whatever the output cannot hold is named in one "
                   "'not kept' warning and in the --json warnings")
      ->required();
  std::vector<std::string> flow_choices = FlowNames();
  flow_choices.insert(flow_choices.begin(), "auto");
  smooth
      ->add_option(
          "--flow", so.flow,
          absl::StrCat(absl::StrJoin(flow_choices, " | "), ". auto (with --iterations auto and no --step): run ",
                       ChoiceFlowNames(), " and keep the result with the smaller estimated error (meshes above ",
                       kMaxChoiceVertices / 1000, absl::StrFormat(",%03d", kMaxChoiceVertices % 1000),
                       " vertices choose flow and count on patches of themselves, where bilateral_normal must be "
                       "better by a margin, then run once); otherwise ",
                       std::string(FlowName(kDefaultFlow))))
      ->capture_default_str()
      ->check(CLI::IsMember(flow_choices));
  smooth
      ->add_option("--iterations", so.iterations,
                   "auto, or a number of iterations to run exactly. auto: estimate the input's noise, "
                   "estimate every iteration's error to the noise-free surface from it (SURE) and keep "
                   "the best iteration; when that turned the faces far less than the noise turns them (a fused "
                   "scan's correlated noise), run until they turned that far instead (a clean mesh comes back "
                   "unchanged, fine detail and all, and so does a mesh every run would leave rougher; closed "
                   "meshes keep their volume); the summary prints the estimate and why it stopped")
      ->transform(CLI::Transformer(std::map<std::string, std::string>{{"auto", "0"}}))
      ->default_str("auto");
  smooth
      ->add_option("--step", so.step,
                   absl::StrCat("lambda: ", StepUnits(flows), "; 0 = the flow's default (see `meshsmooth flows`)"))
      ->capture_default_str();
  smooth
      ->add_option(
          "--weights", so.weights,
          absl::StrCat("umbrella weights of ", FlowsTaking(flows, "weights"), ": u0 uniform, u1 inverse distance"))
      ->capture_default_str()
      ->check(CLI::IsMember({"u0", "u1"}));
  smooth
      ->add_option("--mu", so.mu, absl::StrCat(FlowsTaking(flows, "taubin_mu"), ": mu (> step); 0 = from --pass-band"))
      ->capture_default_str();
  smooth
      ->add_option("--pass-band", so.pass_band,
                   absl::StrCat(FlowsTaking(flows, "taubin_pass_band"),
                                ": k_PB = 1/lambda - 1/mu; 0 = ", DefaultOf(flows, "taubin_pass_band")))
      ->capture_default_str();
  smooth
      ->add_option("--tangential-weight", so.tangential_weight,
                   absl::StrCat(FlowsTaking(flows, "tangential_weight"), ": C; negative = default ",
                                DefaultOf(flows, "tangential_weight")))
      ->capture_default_str();
  smooth
      ->add_option(
          "--epsilon", so.epsilon,
          absl::StrCat(FlowsTaking(flows, "epsilon"), ": epsilon in (0, 1); 0 = default ", DefaultOf(flows, "epsilon")))
      ->capture_default_str();
  smooth
      ->add_option("--normal-iterations", so.normal_iterations,
                   absl::StrCat(FlowsTaking(flows, "normal_filter.normal_iterations"),
                                ": filter passes over the face normals per iteration, 1..100; 0 = ",
                                DefaultOf(flows, "normal_filter.normal_iterations")))
      ->capture_default_str();
  smooth
      ->add_option("--vertex-iterations", so.vertex_iterations,
                   absl::StrCat(FlowsTaking(flows, "normal_filter.vertex_iterations"),
                                ": vertex updates per iteration, 1..100; 0 = ",
                                DefaultOf(flows, "normal_filter.vertex_iterations")))
      ->capture_default_str();
  smooth
      ->add_option("--sigma-spatial", so.sigma_spatial,
                   absl::StrCat(FlowsTaking(flows, "normal_filter.sigma_spatial"),
                                ": spatial sigma relative to the mean distance between adjacent face centroids; 0 = ",
                                DefaultOf(flows, "normal_filter.sigma_spatial")))
      ->capture_default_str();
  smooth
      ->add_option("--sigma-range", so.sigma_range,
                   absl::StrCat(FlowsTaking(flows, "normal_filter.sigma_range"),
                                ": range sigma on |n_i - n_j| of unit normals, (0, 2]; 0 = ",
                                DefaultOf(flows, "normal_filter.sigma_range")))
      ->capture_default_str();
  smooth->add_option("--adaptive", so.adaptive, "eq. (14): none | constant | ring1 | ring2")
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "constant", "ring1", "ring2"}));
  smooth->add_option("--threshold", so.threshold, "T for --adaptive constant")->capture_default_str();
  smooth->add_option("--recompute-every", so.recompute_every, "T(P) recomputed every K iterations")
      ->capture_default_str();
  smooth
      ->add_option(
          "--boundary", so.boundary,
          absl::StrCat("auto | fixed | curve (smooth boundary loops as curves); auto: the default job moves "
                       "the rims of an open mesh when it chooses bilateral_normal (along their faces' normals, "
                       "so holes keep their size) and keeps them with bilaplacian, but for holes at most ",
                       kSmallHoleEdges,
                       " edges around (gaps in the sampling), whose vertices move as interior ones; with "
                       "--flow, fixed"))
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "fixed", "curve"}));
  smooth->add_flag("--implicit", so.implicit,
                   "implicit steps, stable for any --step up to 1e6 (laplacian, bilaplacian, mcf; boundary fixed): one "
                   "sparse solve per iteration; backward Euler unless --theta");
  smooth->add_option("--theta", so.theta,
                     "with --implicit: the weight of the new positions, 0.5..1: 1 = backward Euler (the default), 0.5 "
                     "= Crank-Nicolson (second order in the step)");
  smooth->add_option("--tolerance", so.tolerance, "stop when the largest move < tolerance x mean edge; 0 = off")
      ->capture_default_str();
  smooth
      ->add_option("--quantization-bits", so.quantization_bits,
                   "result positions: 0 = lossless (exact float32), 1..24 = quantized")
      ->capture_default_str()
      ->check(CLI::Range(0, meshsmooth::kMaxQuantizationBits));
  smooth->add_flag(
      "--edgebreaker", so.edgebreaker,
      "encode the result with Edgebreaker (reorders vertices: for a .drc or glTF output, or a .drc input)");
  smooth->add_flag("--gltf-draco", so.gltf_draco,
                   "glTF output: Draco-compress every primitive (KHR_draco_mesh_compression; positions and texture "
                   "coordinates quantized to 16 bits, normals to 12). Default: plain float32 accessors, every value "
                   "kept");
  smooth->add_flag("-q,--quiet", so.quiet,
                   "print nothing but errors and warnings (what the output could not keep is always said)");
  smooth->add_flag("--json", so.json, "print the job summary as JSON on stdout (no progress)");
  smooth->add_flag("--ridges", so.ridges,
                   "detect ridge and ravine vertices after smoothing (paper Section 5); PLY output gets them as "
                   "vertex colours (ridges black, ravines white, others grey), .drc output as attributes");
  smooth
      ->add_option("--ridge-threshold", so.ridge_threshold,
                   "with --ridges: ignore features with |curvature| at or below this (1/mesh units)")
      ->capture_default_str();
  smooth->add_option(
      "--max-displacement", so.max_displacement,
      "D or Dh: a bound on displacement, no vertex ends farther than D mesh units (Dh: D mean edge "
      "lengths of the input, e.g. 0.5h) from its input position. Every flow keeps it as it runs (a "
      "vertex leaving the ball around its input position goes back onto it after each iteration, and the "
      "flow goes on from there); the default job returns no more folded faces than it got. The "
      "summary prints how many vertices reached the bound (99.9% of it or more); 0 = no bound");
  smooth->add_option(
      "--job-id", so.job_id,
      "the job's id in the server's log and the summary (1-128 printable ASCII characters, no "
      "spaces); default: the server makes one up. Retries send the same id. A batch's jobs are ID-1, ID-2, ... "
      "in input order");
  // Per-vertex strength (client/strength.h), sent as JobSpec.strength_attribute.
  AddStrengthOptions(smooth, so.strength);
}

void AddBatchOptions(CLI::App* smooth, BatchOptions& batch) {
  smooth->add_option(
      "--batch", batch.list_file,
      "a batch (so do several inputs, a folder, a glob pattern, or -o ending in '/'): smooth the inputs listed in "
      "this file too, one a line (files, folders, glob patterns, builtin:NAME; relative to the current folder; # "
      "starts a comment line; - reads standard input), each into -o FOLDER/STEM.EXT with the options given, over one "
      "connection; a failed file does not stop the others. Prints a progress line per file on stderr, a summary line "
      "per file and a total on stdout (--json: one object per line; --quiet: neither), and names each failed file "
      "with its error; exit 1 when any failed. Two inputs with the same output, an output over an input, or a glTF "
      "input: exit 2 before any job");
  smooth
      ->add_option("--format", batch.format,
                   "a batch's output format: the extension of every output; default: each input's own (ply for "
                   "builtin:NAME)")
      ->check(CLI::IsMember({"obj", "ply", "off", "stl", "drc", "glb", "gltf"}));
  smooth
      ->add_option("--jobs", batch.jobs,
                   absl::StrCat("a batch's files in flight at once, 1..", kMaxBatchJobs,
                                "; with --server, calls on one channel (spread over its replicas), without it jobs "
                                "in this process"))
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxBatchJobs));
}

// After parsing: a batch, or a single run whose -o names a format the CLI writes. 0 when the command line holds,
// otherwise kExitUsage after saying why.
int SettleSmoothInputs(SmoothOptions& so, const BatchOptions& batch, bool& batch_mode) {
  if (batch.inputs.empty() && batch.list_file.empty()) {
    std::fprintf(stderr,
                 "input is required: a mesh file, several, a folder, a glob pattern, or --batch FILE\n"
                 "Run with --help for more information.\n");
    return kExitUsage;
  }
  batch_mode = IsBatch(batch.inputs, batch.list_file, so.output);
  if (batch_mode) return 0;
  so.input = batch.inputs.front();
  if (!batch.format.empty()) {
    std::fprintf(stderr,
                 "meshsmooth: --format names a batch's output format (-o FOLDER); for one input, the "
                 "extension of -o FILE picks it\n");
    return kExitUsage;
  }
  // As CLI11 reports a validator's refusal.
  std::string output = so.output;
  if (const std::string error = KnownOutputFormat()(output); !error.empty()) {
    std::fprintf(stderr, "--output: %s\nRun with --help for more information.\n", error.c_str());
    return kExitUsage;
  }
  return 0;
}

void AddConnectionOptions(CLI::App* app, ConnectionOptions& c) {
  app->add_option("--server", c.server,
                  "meshsmoothd replicas, any gRPC target: HOST:PORT, dns:///NAME:PORT (every address the name "
                  "has), ipv4:IP:PORT,IP:PORT, unix:PATH, or a list IP:PORT,IP:PORT; calls go round-robin over "
                  "the addresses. Default: an in-process server")
      ->check([](const std::string& s) {
        absl::StatusOr<std::string> target = ChannelTarget(s);
        return target.ok() ? std::string() : std::string(target.status().message());
      });
  app->add_option("--token-file", c.token_file, "file with the bearer token the server expects")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-ca", c.tls_ca, "PEM CA certificates: connect with TLS")->check(CLI::ExistingFile);
  app->add_option("--timeout", c.timeout_seconds,
                  "deadline of the call (a batch: of each file's), seconds above 0, retries included")
      ->capture_default_str()
      ->check(PositiveSeconds());
  app->add_option(
         "--retries", c.retries,
         "retries of a call refused with UNAVAILABLE, or with RESOURCE_EXHAUSTED for the server's capacity (a "
         "full queue or memory budget; never a limit the mesh exceeds, such as --max-vertices), before any "
         "result arrived, after a random wait of up to 0.2 s, 0.4 s, ... 5 s (a job is a pure function of its "
         "input, so a retry is safe); 0 = none. Without --server (the in-process server) there is no network to "
         "retry over")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
}

// Huge pages save a large input's page faults (the noisy dragon, 16.6 MB, one laplacian
// iteration: 575 against 661 ms through the CLI) but the re-exec costs a second start of the
// program (~20 ms: fandisk, 0.4 MB, 45 against 24 ms); they break even near 4 MB (nefertiti,
// 3.6 MB: 89 against 87 ms). Medians of 5-15 runs, a 2-core Intel Xeon VM (AVX-512).
constexpr std::uintmax_t kHugePagesMinInputBytes = 4u << 20;

bool HugePagesPay(const std::string& input) {
  std::error_code error;
  const std::uintmax_t bytes = std::filesystem::file_size(input, error);
  return !error && bytes >= kHugePagesMinInputBytes;
}

// `enhance IN -o OUT`: its options into `eo` (a job with JobSpec.enhance) and `ec`.
CLI::App* AddEnhanceSubcommand(CLI::App& app, SmoothOptions& eo, ConnectionOptions& ec) {
  eo.enhance = true;
  eo.gain = meshsmooth::EnhanceParams{}.gain;
  CLI::App* enhance = app.add_subcommand(
      "enhance",
      "Sharpen a mesh's detail, the inverse of smoothing, through meshsmoothd (or an in-process server): waves "
      "along the surface shorter than --detail grow by --gain, longer ones stay (screened-Poisson sharpening, one "
      "sparse solve, stable for any gain, or --method inverted-flow); boundary fixed, a closed mesh keeps its "
      "volume, and no face turns over (where one would, its vertices are held back; the summary counts them). A "
      "noisy input is refused (noise is the finest detail and would grow most; exit 1) unless --smooth-first");
  enhance->add_option("input", eo.input, "mesh file or builtin:NAME")->required()->check(KnownInput());
  enhance->add_option("-o,--output", eo.output, "output mesh file")->required()->check(KnownOutputFormat());
  enhance->add_option("--gain", eo.gain, "the factor the detail grows by, in (1, 100]")->capture_default_str();
  enhance->add_option("--detail", eo.detail,
                      absl::StrCat("the detail scale: D in mesh units or Dh in mean edge lengths (e.g. 8h); a wave of "
                                   "that length grows by (1 + gain) / 2, shorter ones by nearly the gain; default ",
                                   meshsmooth::EnhanceParams{}.detail_scale_h, "h"));
  enhance->add_flag("--smooth-first", eo.smooth_first,
                    "a noisy input (one the default job would smooth): smooth it with the default job first, then "
                    "enhance (without: refused, exit 1)");
  enhance
      ->add_option("--method", eo.method,
                   "poisson: one screened-Poisson solve, stable for any gain; inverted-flow: the paper's proposal, "
                   "the umbrella flow run backwards on the band below --detail, each vertex's move per step bounded "
                   "by eq. (14)'s curvature control turned round (at most 1000 steps; bounded, slower)")
      ->check(CLI::IsMember({"poisson", "inverted-flow"}))
      ->capture_default_str();
  enhance->add_flag("-q,--quiet", eo.quiet, "print nothing but errors and warnings");
  enhance->add_flag("--json", eo.json, "print the job summary as JSON on stdout (no progress)");
  AddStrengthOptions(enhance, eo.strength);
  AddConnectionOptions(enhance, ec);
  return enhance;
}

// --quantize-upload[=FRACTION] on `command` (smooth, submit): its value into `value`, parsed after
// the command line (ParseQuantizeUpload). `when` starts the help: when it applies, and "for".
CLI::Option* AddQuantizeUploadOption(CLI::App* command, std::string& value, const std::string& when) {
  return command
      ->add_option("--quantize-upload", value,
                   absl::StrCat(when,
                                " a mesh too large to send losslessly (about 36 bytes a vertex): "
                                "send positions quantized so that no coordinate moves more than FRACTION of the mean "
                                "edge length (0 < FRACTION <= ",
                                kMaxUploadQuantization, "; default ", kDefaultUploadQuantization,
                                "); the bound is printed in mesh units and bits. The job smooths the quantized "
                                "positions: a vertex it does not move comes back at its quantized position. Give the "
                                "value with '=' before the input file "
                                "(--quantize-upload=0.001). Default: a lossless upload"))
      ->expected(0, 1)
      ->type_name("[FRACTION]");
}

// The fraction of a --quantize-upload given on the command line into `fraction` (left as it is
// when the flag was not given); false after printing the error (a usage error, exit 2).
bool ParseQuantizeUpload(const CLI::Option* option, const std::string& value, double& fraction) {
  if (option->count() == 0) return true;
  absl::StatusOr<double> parsed = ParseUploadQuantization(value);
  if (!parsed.ok()) {
    std::fprintf(stderr, "meshsmooth: %s\n", std::string(parsed.status().message()).c_str());
    return false;
  }
  fraction = *parsed;
  return true;
}

// The subcommands of jobs a server keeps (meshsmoothd --job-store); their options go into `jc`
// and their connection into `jcc`.
struct JobSubcommands {
  CLI::App *submit, *status, *watch, *fetch, *cancel, *jobs;
  CLI::Option* submit_quantize;  // --quantize-upload, its value in `quantize_upload`
};
JobSubcommands AddJobSubcommands(CLI::App& app, JobCommand& jc, ConnectionOptions& jcc, std::string& quantize_upload) {
  CLI::App* submit = app.add_subcommand(
      "submit",
      "Upload a mesh as a job the server keeps (meshsmoothd --job-store) and print its id; a broken upload "
      "resumes, and the same input submitted again is the same job");
  submit->add_option("input", jc.input, "mesh file (.obj .ply .off .stl .drc) or builtin:NAME")
      ->required()
      ->check(KnownInput());
  submit->add_option("--flow", jc.flow, "a flow (meshsmooth flows); default: the default job");
  submit->add_option("--iterations", jc.iterations, "iterations; 0 = automatic")->capture_default_str();
  submit->add_option("--request-id", jc.request_id,
                     "the upload's request id (1-128 printable characters); default: the SHA-256 of the spec and the "
                     "upload, so that submitting the same input again gives the same job");
  submit->add_option("--callback", jc.callback_url,
                     "an http:// or https:// URL the server POSTs the job to, signed, when it ends (a server with "
                     "--callback-secret-file; docs/deployment.md)");
  submit->add_flag("--wait", jc.wait, "watch the job to its end, then fetch the result into -o");
  submit->add_option("-o,--output", jc.output, "with --wait: the result's .drc file");
  CLI::Option* submit_quantize = AddQuantizeUploadOption(submit, quantize_upload, "for");
  AddConnectionOptions(submit, jcc);
  CLI::App* status = app.add_subcommand("status", "A kept job's state, progress, times and summary");
  status->add_option("id", jc.job_id, "the job's id (as submit printed it)")->required();
  AddConnectionOptions(status, jcc);
  CLI::App* watch =
      app.add_subcommand("watch", "Follow a kept job to its end, a line per event (resumed after a disconnect)");
  watch->add_option("id", jc.job_id, "the job's id")->required();
  AddConnectionOptions(watch, jcc);
  CLI::App* fetch = app.add_subcommand(
      "fetch", "Download a kept job's result as Draco bytes (resumed after a disconnect, checked by SHA-256)");
  fetch->add_option("id", jc.job_id, "the job's id")->required();
  fetch->add_option("-o,--output", jc.output, "the result's .drc file")->required();
  AddConnectionOptions(fetch, jcc);
  CLI::App* cancel = app.add_subcommand("cancel", "Cancel a kept job (a queued one never runs, a running one stops)");
  cancel->add_option("id", jc.job_id, "the job's id")->required();
  AddConnectionOptions(cancel, jcc);
  CLI::App* jobs = app.add_subcommand("jobs", "List the jobs a server keeps, oldest first");
  jobs->add_option("--state", jc.state, "only jobs in this state")
      ->check(CLI::IsMember({"queued", "running", "succeeded", "failed", "cancelled"}));
  AddConnectionOptions(jobs, jcc);
  return {submit, status, watch, fetch, cancel, jobs, submit_quantize};
}

}  // namespace
}  // namespace meshsmooth::client

int main(int argc, char** argv) {
  using namespace meshsmooth::client;
  // Before any thread exists: Ctrl-C is handled by InterruptWatcher, not by a handler.
  meshsmooth::BlockShutdownSignals();
  if (std::getenv("GRPC_VERBOSITY") == nullptr) gpr_set_log_function(DiscardGrpcLog);

  CLI::App app{"meshsmooth: smooth noisy triangle meshes while making them more regular"};
  app.require_subcommand(1);
  std::string footer =
      "Exit codes: 0 success, 1 the job or the input failed (a batch: any file), 2 bad command line, 3 server "
      "unreachable, 130 interrupted.\nBuilt-in inputs (use as builtin:NAME):";
  for (const auto& [name, what] : BuiltinInputs()) footer += "\n  " + name + ": " + what;
  app.footer(footer);

  SmoothOptions so;
  so.flow = "auto";
  ConnectionOptions sc;
  BatchOptions batch;
  CLI::App* smooth =
      app.add_subcommand("smooth", "Smooth a mesh, or a batch of them, through meshsmoothd (or an in-process server)");
  AddSmoothOptions(smooth, so, batch);
  AddBatchOptions(smooth, batch);
  AddConnectionOptions(smooth, sc);
  smooth
      ->add_option("--max-memory", sc.max_memory_bytes,
                   "without --server: the most memory (bytes) a job may need by its estimate from the mesh's "
                   "vertices and faces (about 270 bytes a vertex for the default job); a larger job is refused "
                   "before it starts, naming both figures. 0 = what this machine has available (MemAvailable)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  std::string quantize_upload;
  CLI::Option* quantize_option = AddQuantizeUploadOption(smooth, quantize_upload, "with --server, for");

  ConnectionOptions fc;
  bool flows_json = false;
  CLI::App* flows = app.add_subcommand("flows", "List the flows with their parameters, defaults and ranges");
  flows->add_flag("--json", flows_json, "print the ListFlows response as JSON");
  AddConnectionOptions(flows, fc);

  std::string info_input = "builtin:noisy-sphere";
  CLI::App* info = app.add_subcommand("info", "Print a mesh's validation report and metrics (locally)");
  info->add_option("input", info_input, "mesh file (.obj .ply .off .stl .drc) or builtin:NAME")
      ->capture_default_str()
      ->check(KnownInput());

  std::string ridges_input, ridges_output;
  std::string ridges_threshold = "auto";
  CLI::App* ridges = app.add_subcommand(
      "ridges", "Detect ridge (black) and ravine (white) vertices of a mesh as it is, locally, into a PLY");
  ridges->add_option("input", ridges_input, "mesh file or builtin:NAME")->required()->check(KnownInput());
  ridges->add_option("-o,--output", ridges_output, "output .ply (labels as vertex colours)")->required();
  ridges
      ->add_option("--threshold", ridges_threshold,
                   "ignore features with |curvature| at or below this: a number in 1/mesh units (0 keeps every "
                   "extremum), or auto: a tenth of the mesh's own curvature scale (the 90th percentile of "
                   "max(|kmax|, |kmin|)), whatever the mesh's units and size")
      ->capture_default_str();

  SmoothOptions eo;
  ConnectionOptions ec;
  CLI::App* enhance = AddEnhanceSubcommand(app, eo, ec);

  RenderCommand rc;
  CLI::App* render = app.add_subcommand(
      "render",
      "Render a mesh to a PNG picture (locally; vertex colours shown, or with --weight, --fixed or --region the "
      "per-vertex strength smooth would send: grey where 0, orange where 1)");
  render->add_option("input", rc.input, "mesh file or builtin:NAME")->capture_default_str()->check(KnownInput());
  render->add_option("-o,--output", rc.output, "output .png")->required();
  render
      ->add_option("--view", rc.view,
                   "front | back | left | right | top | bottom | iso, or AZIMUTH,ELEVATION in degrees")
      ->capture_default_str();
  render->add_option("--size", rc.size, "WIDTHxHEIGHT in pixels (16..8192 each)")->capture_default_str();
  render->add_option("--shading", rc.shading, "gouraud (smooth) | flat (one shade per face)")
      ->check(CLI::IsMember({"gouraud", "flat"}))
      ->capture_default_str();
  AddStrengthOptions(render, rc.strength);

  JobCommand jc;
  ConnectionOptions jcc;
  std::string submit_quantize_upload;
  const JobSubcommands kept = AddJobSubcommands(app, jc, jcc, submit_quantize_upload);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : kExitUsage;
  }
  bool batch_mode = false;
  if (smooth->parsed()) {
    // Before the inputs: given alone before the input file, the flag takes the file as its value.
    if (!ParseQuantizeUpload(quantize_option, quantize_upload, so.quantize_upload)) return kExitUsage;
    if (so.quantize_upload > 0.0 && sc.server.empty()) {
      std::fprintf(stderr,
                   "meshsmooth: --quantize-upload quantizes what is sent to --server; without --server the job runs "
                   "on the mesh as read (nothing is uploaded)\n");
      return kExitUsage;
    }
    if (const int code = SettleSmoothInputs(so, batch, batch_mode); code != 0) return code;
  }
  if (smooth->parsed() || enhance->parsed()) {
    if (absl::Status s = CheckSmoothOptions(smooth->parsed() ? so : eo); !s.ok()) {
      std::fprintf(stderr, "meshsmooth: %s\n", std::string(s.message()).c_str());
      return kExitUsage;
    }
  }
  // Still no thread: the huge-page re-exec (base/huge_pages.h) where the input is large enough
  // to repay a second start of the program (a batch's so.input is empty: its files are read later).
  const std::string& input = smooth->parsed()    ? so.input
                             : info->parsed()    ? info_input
                             : ridges->parsed()  ? ridges_input
                             : enhance->parsed() ? eo.input
                                                 : rc.input;
  if (HugePagesPay(input)) meshsmooth::UseHugePagesForLargeBuffers(argv);
  meshsmooth::ApplyKernelEnvironment();
  if (smooth->parsed()) return batch_mode ? RunBatch(so, sc, batch) : RunSmooth(so, sc);
  if (flows->parsed()) return RunFlows(fc, flows_json);
  if (kept.submit->parsed()) {
    if (!ParseQuantizeUpload(kept.submit_quantize, submit_quantize_upload, jc.quantize_upload)) return kExitUsage;
    return RunSubmit(jc, jcc);
  }
  if (kept.status->parsed()) return RunStatus(jc, jcc);
  if (kept.watch->parsed()) return RunWatch(jc, jcc);
  if (kept.fetch->parsed()) return RunFetch(jc, jcc);
  if (kept.cancel->parsed()) return RunCancel(jc, jcc);
  if (kept.jobs->parsed()) return RunJobs(jc, jcc);
  if (info->parsed()) return RunInfo(info_input);
  if (ridges->parsed()) return RunRidges(ridges_input, ridges_output, ridges_threshold);
  if (enhance->parsed()) return RunSmooth(eo, ec);
  if (render->parsed()) return RunRender(rc);
  return kExitUsage;
}
