// meshsmooth_implicit_bench: time to the same error with implicit steps (FlowParams::integration)
// against the explicit runs. For each mesh (a noisy icosphere, the noisy dragon): the default job
// (explicit, automatic: it chooses the flow F and the count N), F run explicitly for N
// iterations, then F run implicitly in k steps of N lambda / k (the same time of the flow) with
// each solver; every result's RMS distance to the clean surface, its smoothing time, and the
// smoothing's peak memory per vertex measured in a fresh process. Markdown to stdout, progress
// to stderr; docs/performance.md ("Implicit steps") is its output.
#include <malloc.h>
#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "bench/bench_common.h"
#include "bench/quality_inputs.h"
#include "core/flows/catalogue.h"
#include "core/measure/evaluation.h"
#include "core/measure/metrics.h"
#include "core/shapes/parametric.h"

namespace meshsmooth::bench {
namespace {

namespace fs = std::filesystem;

constexpr char kUsage[] =
    "usage: meshsmooth_implicit_bench [--meshes icosphere,stanford-dragon] [--level 9] [--sigma 0.2]\n"
    "                                 [--seed 1] [--steps 1,2,4] [--solvers cg,direct]\n"
    "                                 [--cg-tolerances 1e-8,1e-4,1e-2] [--time-scales 1] [--max-direct 700000]\n"
    "                                 [--flow F] [--shared DIR]\n"
    "Time to the same error, implicit against explicit steps. For each mesh (icosphere: Icosphere(--level),\n"
    "the distance to the clean surface measured to the unit sphere; else a mesh of DIR/data/meshes, measured\n"
    "with the quality benchmark's GroundTruth), Gaussian noise of --sigma h along the normals (seed --seed),\n"
    "then: the default job (explicit, automatic; it chooses flow F and count N); F explicit for N iterations;\n"
    "F implicit (backward Euler) in k steps of s N lambda / k for each k of --steps and s of --time-scales and each "
    "solver (direct only\n"
    "up to --max-direct vertices; CG at each of --cg-tolerances, its relative residual). Each row: RMS distance to the "
    "clean surface (h), smoothing time (s,\n"
    "in-process, all threads), the ratio to the default job's, and the smoothing's peak memory in a fresh\n"
    "process (the growth of VmHWM over the process holding the mesh and its topology, and the whole\n"
    "process's VmHWM, bytes per vertex). --flow F (laplacian, bilaplacian, mcf) runs F explicitly and implicitly in\n"
    "place of the default job's flow, for the default job's count N.\n";

struct Options {
  std::vector<std::string> meshes = {"icosphere", "stanford-dragon"};
  int level = 9;
  double sigma = 0.2;
  uint64_t seed = 1;
  std::vector<int> steps = {1, 2, 4};
  std::vector<std::string> solvers = {"cg", "direct"};
  std::vector<double> cg_tolerances = {1e-8, 1e-4, 1e-2};
  std::vector<double> time_scales = {1.0};
  int32_t max_direct = 700000;
  std::string flow;  // empty: the default job's
  fs::path shared = fs::path(MESHSMOOTH_SOURCE_DIR) / ".." / "shared";
};

// The clean and noisy mesh of `name` and the RMS distance of a result to the clean surface, in h.
struct Input {
  Mesh clean, noisy;
  std::unique_ptr<GroundTruth> truth;  // null for the icosphere
  double h = 0.0;
  double Rms(const Mesh& m) const {
    if (truth) {
      const absl::StatusOr<Quality> q = truth->Evaluate(m);
      return q.ok() ? q->rms_distance : std::nan("");
    }
    double sum = 0.0;
    for (const Vec3& p : m.positions) sum += (Norm(p) - 1.0) * (Norm(p) - 1.0);
    return std::sqrt(sum / static_cast<double>(m.positions.size())) / h;
  }
};

absl::StatusOr<Input> MakeInput(const std::string& name, const Options& opt) {
  Input in;
  if (name == "icosphere") {
    in.clean = Icosphere(opt.level);
  } else {
    absl::StatusOr<Subject> subject = LoadSubject(name, opt.shared / "data" / "meshes");
    if (!subject.ok()) return subject.status();
    in.clean = subject->truth->mesh();
    in.truth = std::move(subject->truth);
  }
  in.h = MeanEdgeLength(in.clean, BuildTopology(in.clean));
  in.noisy = MakeNoisy(in.clean, Case{Noise::kNormal, opt.sigma}, opt.seed);
  return in;
}

FlowParams RunParams(const std::string& flow, int iterations, double step, const std::string& solver,
                     double cg_tolerance = 1e-8) {
  FlowParams p;
  if (flow == "auto") return p;  // the default job
  p.flow = ParseFlowName(flow).value();
  p.iterations = iterations;
  p.step = step;
  if (solver != "explicit") {
    p.integration = Integration::kImplicit;
    p.implicit_solver = solver == "cg" ? ImplicitSolver::kCg : ImplicitSolver::kDirect;
    p.cg_tolerance = cg_tolerance;
  }
  return p;
}

// `--peak-child MESH FLOW ITERATIONS STEP SOLVER CG_TOLERANCE` with the parent's --level, --sigma, --seed,
// --shared: the smoothing's growth of VmHWM and the whole VmHWM, bytes per vertex.
int PeakChild(const Options& opt, const std::vector<std::string>& args) {
  absl::StatusOr<Input> in = MakeInput(args[0], opt);
  if (!in.ok()) return 1;
  in->truth.reset();
  Mesh mesh = std::move(in->noisy);
  in->clean = Mesh();
  Topology topo = BuildTopology(mesh);
  malloc_trim(0);  // the input's making (the clean mesh, the ground truth) gives its memory back
  { std::ofstream("/proc/self/clear_refs") << "5"; }  // VmHWM back to the resident set
  const double base = StatusKb("VmRSS:") * 1024.0;
  int iterations = 0;
  double step = 0.0;
  double tolerance = 0.0;
  if (!absl::SimpleAtoi(args[2], &iterations) || !absl::SimpleAtod(args[3], &step) ||
      !absl::SimpleAtod(args[5], &tolerance)) {
    return 1;
  }
  if (!Smooth(mesh, topo, RunParams(args[1], iterations, step, args[4], tolerance)).ok()) return 1;
  const double hwm = StatusKb("VmHWM:") * 1024.0;
  std::printf("%f %f\n", (hwm - base) / mesh.num_vertices(), hwm / mesh.num_vertices());
  return 0;
}

struct Peak {
  double run = -1.0, whole = -1.0;
};

Peak MeasurePeak(const std::string& self, const Options& opt, const std::string& mesh, const std::string& flow,
                 int iterations, double step, const std::string& solver, double cg_tolerance = 1e-8) {
  const std::string command = absl::StrFormat(
      "%s --level %d --sigma %g --seed %d --shared %s --peak-child %s %s %d %.17g %s %g", self, opt.level, opt.sigma,
      opt.seed, opt.shared.string(), mesh, flow, iterations, step, solver, cg_tolerance);
  Peak peak;
  if (std::FILE* f = popen(command.c_str(), "r")) {
    if (std::fscanf(f, "%lf %lf", &peak.run, &peak.whole) != 2) peak = {};
    pclose(f);
  }
  return peak;
}

struct Row {
  std::string what;
  double rms = 0.0, seconds = 0.0;
  Peak peak;
};

void PrintTable(const std::string& mesh, int32_t n, const std::vector<Row>& rows, double reference_rms,
                double reference_seconds) {
  std::printf("\n### %s, %d vertices\n\n", mesh.c_str(), n);
  std::printf(
      "| run | RMS (h) | RMS / default job's | smoothing (s) | time / default job's | peak of the run (B/vertex) | "
      "peak of the process (B/vertex) |\n|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows) {
    std::printf("| %s | %.4f | %.3f | %.3f | %.3f | %s | %s |\n", r.what.c_str(), r.rms, r.rms / reference_rms,
                r.seconds, r.seconds / reference_seconds,
                r.peak.run < 0 ? "-" : absl::StrFormat("%.0f", r.peak.run).c_str(),
                r.peak.whole < 0 ? "-" : absl::StrFormat("%.0f", r.peak.whole).c_str());
  }
  std::fflush(stdout);
}

int RunMesh(const std::string& self, const std::string& name, const Options& opt) {
  std::fprintf(stderr, "%s: making the input\n", name.c_str());
  absl::StatusOr<Input> in = MakeInput(name, opt);
  if (!in.ok()) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), in.status().ToString().c_str());
    return 1;
  }
  Topology topo = BuildTopology(in->noisy);
  const int32_t n = in->noisy.num_vertices();
  std::vector<Row> rows;
  rows.push_back({"noisy input", in->Rms(in->noisy), 0.0, {}});

  std::fprintf(stderr, "%s: the default job\n", name.c_str());
  Mesh job = in->noisy;
  Clock::time_point t0 = Clock::now();
  const absl::StatusOr<FlowResult> chosen = Smooth(job, topo, FlowParams{});
  const double job_seconds = Seconds(t0, Clock::now());
  if (!chosen.ok() || chosen->iterations_run == 0) {
    std::fprintf(stderr, "%s: the default job did not smooth\n", name.c_str());
    return 1;
  }
  const std::string flow = opt.flow.empty() ? std::string(FlowName(chosen->flow)) : opt.flow;
  const int count = chosen->iterations_run;
  const double job_rms = in->Rms(job);
  rows.push_back(
      {absl::StrFormat("default job: %s, %d iterations (explicit, automatic)", FlowName(chosen->flow), count),
       job_rms,
       job_seconds,
       {}});

  const double step = DefaultStep(ParseFlowName(flow).value());
  std::fprintf(stderr, "%s: %s explicit, %d iterations\n", name.c_str(), flow.c_str(), count);
  Mesh ex = in->noisy;
  t0 = Clock::now();
  if (!Smooth(ex, topo, RunParams(flow, count, step, "explicit")).ok()) return 1;
  rows.push_back({absl::StrFormat("%s explicit, %d iterations of %g", flow, count, step), in->Rms(ex),
                  Seconds(t0, Clock::now()), MeasurePeak(self, opt, name, flow, count, step, "explicit")});
  // The default job's peak, for comparison: the automatic run in a fresh process.
  rows[1].peak = MeasurePeak(self, opt, name, "auto", 0, 0.0, "explicit");
  PrintTable(name, n, rows, job_rms, job_seconds);

  for (const std::string& solver : opt.solvers) {
    if (solver == "direct" && n > opt.max_direct) continue;
    for (double tolerance : solver == "cg" ? opt.cg_tolerances : std::vector<double>{1e-8}) {
      for (int k : opt.steps) {
        for (double scale : opt.time_scales) {
          const double big = scale * step * count / k;
          const std::string what =
              absl::StrFormat("%s implicit, %s, %d steps of %g", flow,
                              solver == "cg" ? absl::StrFormat("CG to %g", tolerance) : solver, k, big);
          std::fprintf(stderr, "%s: %s\n", name.c_str(), what.c_str());
          Mesh im = in->noisy;
          t0 = Clock::now();
          const absl::StatusOr<FlowResult> r = Smooth(im, topo, RunParams(flow, k, big, solver, tolerance));
          const double seconds = Seconds(t0, Clock::now());
          if (!r.ok()) {
            std::fprintf(stderr, "  failed: %s\n", r.status().ToString().c_str());
            continue;
          }
          rows.push_back({what, in->Rms(im), seconds, MeasurePeak(self, opt, name, flow, k, big, solver, tolerance)});
          std::fprintf(stderr, "  RMS %.4f h, %.3f s\n", rows.back().rms, seconds);
        }
      }
    }
  }
  PrintTable(name, n, rows, job_rms, job_seconds);
  return 0;
}

int Main(int argc, char** argv) {
  Options opt;
  std::vector<std::string> child;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (a == "--peak-child") {
      for (++i; i < argc; ++i) child.emplace_back(argv[i]);
      break;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s needs a value\n%s", a.c_str(), kUsage);
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--meshes") {
      opt.meshes = absl::StrSplit(v, ',');
    } else if (a == "--level") {
      opt.level = std::atoi(v.c_str());
    } else if (a == "--sigma") {
      opt.sigma = std::atof(v.c_str());
    } else if (a == "--seed") {
      opt.seed = std::strtoull(v.c_str(), nullptr, 10);
    } else if (a == "--steps") {
      opt.steps.clear();
      for (absl::string_view s : absl::StrSplit(v, ',')) opt.steps.push_back(std::atoi(std::string(s).c_str()));
    } else if (a == "--solvers") {
      opt.solvers = absl::StrSplit(v, ',');
    } else if (a == "--cg-tolerances") {
      opt.cg_tolerances.clear();
      for (absl::string_view t : absl::StrSplit(v, ',')) opt.cg_tolerances.push_back(std::atof(std::string(t).c_str()));
    } else if (a == "--time-scales") {
      opt.time_scales.clear();
      for (absl::string_view t : absl::StrSplit(v, ',')) opt.time_scales.push_back(std::atof(std::string(t).c_str()));
    } else if (a == "--max-direct") {
      opt.max_direct = std::atoi(v.c_str());
    } else if (a == "--flow") {
      const absl::StatusOr<FlowId> id = ParseFlowName(v);
      if (!id.ok() || !HasImplicitForm(*id)) {
        std::fprintf(stderr, "--flow %s: not a flow with an implicit form\n%s", v.c_str(), kUsage);
        return 2;
      }
      opt.flow = v;
    } else if (a == "--shared") {
      opt.shared = v;
    } else {
      std::fprintf(stderr, "unknown option %s\n%s", a.c_str(), kUsage);
      return 2;
    }
  }
  if (!child.empty()) return child.size() == 6 ? PeakChild(opt, child) : 2;
  const std::string self = fs::canonical("/proc/self/exe").string();
  int status = 0;
  for (const std::string& name : opt.meshes) status |= RunMesh(self, name, opt);
  return status;
}

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) { return meshsmooth::bench::Main(argc, argv); }
