// The quality benchmark: the mesh-denoising literature's protocol on the real meshes clean
// enough to serve as ground truth and on the synthetic shapes. Each clean mesh gets Gaussian
// noise along its vertex normals (sigma = 0, 0.1, 0.2, 0.3, 0.5, 0.7 of its mean edge length h,
// several seeds), in random directions and impulsive noise; then the default job (a default
// JobSpec through the service's FromProto), BNF and GNF as their authors' code runs by default,
// every flow of the flow table at its best iteration count ("oracle"), and any job given on the
// command line run on it, and core/measure/evaluation.h measures each
// result against the clean mesh. Then the scan cases (quality_scans.cc): the clean meshes as
// simulated depth cameras scan them and the real Kinect-Fusion cone. Markdown tables to stdout; docs/quality.md is its
// output:
//   nice -n 10 build/bench/meshsmooth_quality --seeds 1 > docs/quality.md
// docs/quality-method.md, written by hand, says how to read them; a change to what the tables
// measure changes it too. `--help` lists the options; `--quick` runs a subset in about two
// minutes.
//
// This file holds the options and main; quality_inputs.cc the meshes and noise, quality_runs.cc
// the jobs and oracle sweeps, quality_tables.cc the tables, quality_paper.cc the paper's setting,
// quality_scans.cc the scan cases.
#include <sys/resource.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "base/huge_pages.h"
#include "base/kernel_environment.h"
#include "bench/bench_common.h"
#include "bench/quality_inputs.h"
#include "bench/quality_paper.h"
#include "bench/quality_runs.h"
#include "bench/quality_scans.h"
#include "bench/quality_tables.h"
#include "core/flows/flow.h"
#include "core/io/mesh_io.h"
#include "core/job/policy.h"
#include "core/measure/evaluation.h"

namespace meshsmooth::bench {
namespace {

// What the command line asks for (kUsage).
struct Options {
  std::filesystem::path shared = std::filesystem::path(MESHSMOOTH_SOURCE_DIR) / ".." / "shared";
  std::vector<std::string> meshes = kDefaultMeshes;
  std::vector<double> sigmas = {0.0, 0.1, 0.2, 0.3, 0.5, 0.7};
  std::vector<double> random_sigmas = {0.1, 0.2, 0.3};
  std::vector<double> impulsive = {1.0};
  int seeds = 3;
  uint64_t first_seed = 1;         // kHeldOutFirstSeed with --held-out
  int large_seeds = 1;             // 0: as many as `seeds`
  std::vector<std::string> flows;  // empty: every flow of the table, unless no_flows
  bool no_flows = false;
  std::vector<std::string> jobs, oracle_jobs;  // JobSpecs in protobuf text format
  bool paper = true;
  int paper_iterations = 20;
  bool scans = true;
  bool scan_oracles = true;  // the oracle rows of bilateral_normal and guided_normal on the scans
  ScanOptions scan;
  bool policy_changed = false;  // --policy: an ablation
};

// The synthetic cases' first held-out seed (--held-out); the tuning seeds are 1, 2, ...
constexpr uint64_t kHeldOutFirstSeed = 1001;

// The machine the header names.
std::string CpuModel() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) {
      return std::string(absl::StripAsciiWhitespace(line.substr(line.find(':') + 1)));
    }
  }
  return "unknown CPU";
}

// The numbers of a comma-separated list.
std::vector<double> ParseDoubles(const std::string& s) {
  std::vector<double> v;
  for (absl::string_view part : absl::StrSplit(s, ',', absl::SkipEmpty())) {
    v.push_back(std::atof(std::string(part).c_str()));
  }
  return v;
}

// Today's policy (job::kPolicy) with the fields `spec` names ("name=value,name=value") set, or
// InvalidArgument naming an unknown field or a value that is not a number.
absl::StatusOr<job::JobPolicy> ParsePolicy(const std::string& spec) {
  job::JobPolicy policy = job::kPolicy;
  for (absl::string_view item : absl::StrSplit(spec, ',', absl::SkipEmpty())) {
    const std::vector<std::string> kv = absl::StrSplit(item, absl::MaxSplits('=', 1));
    bool found = false, parsed = false;
    if (kv.size() == 2) {
      job::VisitPolicy(policy, [&](const char* name, auto& value) {
        if (kv[0] != name) return;
        found = true;
        double number = 0.0;
        parsed = absl::SimpleAtod(kv[1], &number) && std::isfinite(number);
        if (parsed) value = static_cast<std::remove_reference_t<decltype(value)>>(number);
      });
    }
    if (!found || !parsed) {
      return absl::InvalidArgumentError(absl::StrCat("--policy: '", item,
                                                     "' is not NAME=NUMBER with a field of JobPolicy "
                                                     "(--list-policy lists them)"));
    }
  }
  return policy;
}

// The line under the header: the method is hand-written, not generated.
constexpr char kMethodPointer[] =
    "\nHow the inputs, noise, measures, rows and targets are defined, and how the defaults were chosen: "
    "[docs/quality-method.md](quality-method.md).\n";

constexpr char kUsage[] =
    "usage: meshsmooth_quality [--meshes a,b,...] [--sigmas 0,0.1,0.2,0.3,0.5,0.7] [--random-sigmas 0.1,0.2,0.3]\n"
    "                          [--seeds 3] [--large-seeds 1] [--flows a,b,...] [--job SPEC]... [--oracle-job SPEC]...\n"
    "                          [--shared DIR] [--paper-iterations 20] [--no-paper] [--quick]\n"
    "                          [--scan-meshes a,b,...] [--scan-kinds tof,sl,fused] [--scan-seeds 2]\n"
    "                          [--held-out] [--scan-set held-out|tuning] [--no-scans] [--no-real] [--scan-quick]\n"
    "                          [--policy NAME=VALUE,...] [--list-policy]\n"
    "  --meshes         real meshes by file name without extension, and `sphere`, `two-rate-torus`,\n"
    "                   `mt-torus`, `mt-cylinder`, `holey-sphere`,\n"
    "                   `perforated-sphere`\n"
    "  --sigmas         Gaussian noise along the normals, in mean edge lengths h (0 = the clean mesh)\n"
    "  --random-sigmas  Gaussian noise in random directions (\"\": none)\n"
    "  --impulsive      impulsive noise: 10% of the vertices thrown S h to 3 S h along their normals,\n"
    "                   for each S listed (default 1; \"\": none)\n"
    "  --seeds          noisy copies per mesh and sigma; --large-seeds for meshes of 200k+ vertices\n"
    "                   (default 1; 0: as --seeds)\n"
    "  --flows          oracle rows for these flows of the flow table (default: all; `none`: none);\n"
    "                   the default job's row and the authors' BNF and GNF rows are always there\n"
    "  --job SPEC       one more row: a meshsmooth.v1.JobSpec in protobuf text format, run as given,\n"
    "                   e.g. --job 'flow: \"median\" iterations: 5 boundary: BOUNDARY_MODE_CURVE'\n"
    "  --oracle-job SPEC  the same, swept over iteration counts like the flows' rows\n"
    "  --shared DIR     the folder holding data/meshes (default: ../shared beside the source tree)\n"
    "  --no-paper       skip the fixed-iteration tables of the paper's setting\n"
    "  --quick          fandisk, bunny-small and the sphere, sigma 0 and 0.2 (random: 0.2), one seed,\n"
    "                   no paper tables, no scans\n"
    "  --held-out       the synthetic cases' noisy copies from the held-out seeds 1001, 1002, ... rather\n"
    "                   than 1, 2, ... (the seeds the defaults were tuned on)\n"
    "  --scan-meshes    clean meshes the scan cases scan (default fandisk,stanford-bunny,nefertiti,sphere)\n"
    "  --scan-kinds     tof (time-of-flight frame), sl (structured-light frame), fused (frames fused in a\n"
    "                   voxel volume); default all three\n"
    "  --scan-seeds     scans per mesh and kind, each from its own seed and pose (default 2)\n"
    "  --scan-set       held-out (default: the seeds and poses docs/quality.md reports) or tuning\n"
    "  --no-scans       skip the scan cases; --no-real skips the real cone of DIR/data/real\n"
    "  --scan-quick     only the scan cases and the real cone, one seed each, without the oracle rows:\n"
    "                   the default job against BNF and GNF on scanner noise in a few minutes\n"
    "  --policy NAME=VALUE,...  the default job with these numbers of its policy changed (core/job/policy.h):\n"
    "                   an ablation; the header says so\n"
    "  --list-policy    print the policy's numbers, NAME=VALUE a line, and exit\n"
    "  --write-scan MESH KIND INDEX OUT  only write scan INDEX (0, 1, ...) of MESH of KIND (tof, sl,\n"
    "                   fused) as the scan cases make it (after --scan-set, if given; metres) to OUT, and exit\n"
    "  --write-noisy MESH SIGMA SEED OUT [random|impulsive]  only write the benchmark's input for MESH\n"
    "                   with Gaussian noise of SIGMA h along the normals (or in random directions, or\n"
    "                   impulsive noise of scale SIGMA) and SEED (as the tables use it) to OUT, and exit\n";

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) {
  meshsmooth::UseHugePagesForLargeBuffers(argv);  // first: may re-execute the program
  meshsmooth::ApplyKernelEnvironment();
  using namespace meshsmooth;
  using namespace meshsmooth::bench;
  const Clock::time_point start = Clock::now();
  Options opt;
  std::vector<std::string> command = {"build/bench/meshsmooth_quality"};
  // An argument as a shell would need it typed: quoted when it holds a space or is empty.
  auto quoted = [](const std::string& s) { return s.empty() || s.find(' ') != std::string::npos ? "'" + s + "'" : s; };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    command.push_back(quoted(a));
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fputs(kUsage, stderr);
        std::exit(2);
      }
      command.push_back(quoted(argv[i + 1]));
      return argv[++i];
    };
    if (a == "--meshes") {
      opt.meshes = absl::StrSplit(next(), ',', absl::SkipEmpty());
    } else if (a == "--sigmas") {
      opt.sigmas = ParseDoubles(next());
    } else if (a == "--random-sigmas") {
      opt.random_sigmas = ParseDoubles(next());
    } else if (a == "--impulsive") {
      opt.impulsive = ParseDoubles(next());
    } else if (a == "--seeds") {
      opt.seeds = std::max(1, std::atoi(next().c_str()));
    } else if (a == "--large-seeds") {
      opt.large_seeds = std::max(0, std::atoi(next().c_str()));
    } else if (a == "--flows") {
      opt.flows = absl::StrSplit(next(), ',', absl::SkipEmpty());
      opt.no_flows = opt.flows == std::vector<std::string>{"none"};
      if (opt.no_flows) opt.flows.clear();
      for (const std::string& f : opt.flows) {
        if (absl::StatusOr<FlowId> id = ParseFlowName(f); !id.ok()) {
          std::fprintf(stderr, "%s\n", id.status().ToString().c_str());
          return 2;
        }
      }
    } else if (a == "--job") {
      opt.jobs.push_back(next());
    } else if (a == "--oracle-job") {
      opt.oracle_jobs.push_back(next());
    } else if (a == "--shared") {
      opt.shared = next();
    } else if (a == "--paper-iterations") {
      opt.paper_iterations = std::atoi(next().c_str());
    } else if (a == "--no-paper") {
      opt.paper = false;
    } else if (a == "--write-noisy") {
      const std::string name = next(), sigma = next(), seed = next(), out = next();
      absl::StatusOr<Subject> subject = LoadSubject(name, opt.shared / "data" / "meshes");
      if (!subject.ok()) {
        std::fprintf(stderr, "meshsmooth_quality: %s\n", subject.status().ToString().c_str());
        return 1;
      }
      // An optional fifth word names the noise: normal (the default), random or impulsive.
      Noise kind = Noise::kNormal;
      if (i + 1 < argc && (std::string(argv[i + 1]) == "random" || std::string(argv[i + 1]) == "impulsive")) {
        kind = next() == "random" ? Noise::kRandom : Noise::kImpulsive;
      }
      const Mesh noisy = MakeNoisy(subject->truth->mesh(), Case{kind, std::atof(sigma.c_str())},
                                   std::strtoull(seed.c_str(), nullptr, 10));
      if (absl::Status s = WriteMesh(out, noisy); !s.ok()) {
        std::fprintf(stderr, "meshsmooth_quality: %s\n", s.ToString().c_str());
        return 1;
      }
      return 0;
    } else if (a == "--write-scan") {
      const std::string name = next(), kind = next(), index = next(), out = next();
      absl::StatusOr<Subject> subject = LoadSubject(name, opt.shared / "data" / "meshes");
      absl::StatusOr<std::vector<ScanKind>> k = ParseScanKinds(kind);
      if (!subject.ok() || !k.ok() || k->size() != 1) {
        std::fprintf(stderr, "meshsmooth_quality: %s\n",
                     (subject.ok() ? k.status() : subject.status()).ToString().c_str());
        return 1;
      }
      const Mesh scan =
          MakeScan(ToObjectScale(subject->truth->mesh()), (*k)[0], opt.scan.held_out, std::atoi(index.c_str()));
      if (absl::Status s = WriteMesh(out, scan); !s.ok()) {
        std::fprintf(stderr, "meshsmooth_quality: %s\n", s.ToString().c_str());
        return 1;
      }
      return 0;
    } else if (a == "--held-out") {
      opt.first_seed = kHeldOutFirstSeed;
    } else if (a == "--policy") {
      absl::StatusOr<job::JobPolicy> policy = ParsePolicy(next());
      if (!policy.ok()) {
        std::fprintf(stderr, "meshsmooth_quality: %s\n", policy.status().ToString().c_str());
        return 2;
      }
      SetJobPolicy(*policy);
      opt.policy_changed = true;
    } else if (a == "--list-policy") {
      job::JobPolicy policy = job::kPolicy;
      job::VisitPolicy(
          policy, [](const char* name, auto& value) { std::printf("%s=%s\n", name, absl::StrCat(value).c_str()); });
      return 0;
    } else if (a == "--scan-meshes") {
      opt.scan.meshes = absl::StrSplit(next(), ',', absl::SkipEmpty());
    } else if (a == "--scan-kinds") {
      absl::StatusOr<std::vector<ScanKind>> kinds = ParseScanKinds(next());
      if (!kinds.ok()) {
        std::fprintf(stderr, "%s\n", kinds.status().ToString().c_str());
        return 2;
      }
      opt.scan.kinds = *kinds;
    } else if (a == "--scan-seeds") {
      opt.scan.seeds = std::max(1, std::atoi(next().c_str()));
    } else if (a == "--scan-set") {
      const std::string set = next();
      if (set != "held-out" && set != "tuning") {
        std::fputs(kUsage, stderr);
        return 2;
      }
      opt.scan.held_out = set == "held-out";
    } else if (a == "--no-scans") {
      opt.scans = false;
    } else if (a == "--no-real") {
      opt.scan.real = false;
    } else if (a == "--scan-quick") {
      opt.meshes.clear();
      opt.paper = false;
      opt.scan.seeds = 1;
      opt.scan_oracles = false;
    } else if (a == "--quick") {
      opt.meshes = {"fandisk", "bunny-small", "sphere"};
      opt.sigmas = {0.0, 0.2};
      opt.random_sigmas = {0.2};
      opt.impulsive = {};
      opt.seeds = 1;
      opt.paper = false;
      opt.scans = false;
    } else {
      std::fputs(kUsage, stderr);
      return a == "--help" ? 0 : 2;
    }
  }
  const std::vector<Job> jobs = MakeJobs(opt.flows, opt.no_flows, opt.jobs, opt.oracle_jobs);
  const std::vector<Case> cases = MakeCases(opt.sigmas, opt.random_sigmas, opt.impulsive);
  const std::filesystem::path mesh_dir = opt.shared / "data" / "meshes";

  std::string body, inputs;
  std::vector<std::vector<MeshCase>> results(cases.size());
  std::vector<std::string> details;
  for (const std::string& name : opt.meshes) {
    absl::StatusOr<Subject> subject = LoadSubject(name, mesh_dir);
    if (!subject.ok()) {
      SkippedInputRow(inputs, name, subject.status());
      continue;
    }
    const GroundTruth& truth = *subject->truth;
    const int seeds = truth.mesh().num_vertices() >= kLargeMesh && opt.large_seeds > 0 ? opt.large_seeds : opt.seeds;
    std::string detail = absl::StrFormat("\n### %s\n", name);
    double eval_seconds = 0.0;
    for (size_t ci = 0; ci < cases.size(); ++ci) {
      const Case& c = cases[ci];
      const int n = c.sigma == 0.0 ? 1 : seeds;  // the clean input has no seed
      std::vector<Mesh> noisy;
      for (int s = 0; s < n; ++s)
        noisy.push_back(MakeNoisy(truth.mesh(), c, opt.first_seed + static_cast<uint64_t>(s)));
      const std::vector<Input> runs_on = CopiesOf(truth, noisy);
      MeshCase mc{name, InputRow(c.sigma == 0.0 ? "clean input" : "noisy input", runs_on), JobRows(jobs, runs_on)};
      if (c.sigma > 0.0 && eval_seconds == 0.0) eval_seconds = OneThreadEvaluationSeconds(truth, noisy[0]);
      DetailTable(detail, c.Name(), mc, n);
      results[ci].push_back(std::move(mc));
      std::fprintf(stderr, "%s, %s: done at %.0f s\n", name.c_str(), c.Name().c_str(), Seconds(start, Clock::now()));
    }
    details.push_back(detail);
    InputsRow(inputs, *subject, seeds, eval_seconds);
  }

  if (!opt.meshes.empty()) {
    InputsTable(body, inputs);
    body += "\n## Summary: the default job against the noisy input and the best oracle row\n";
    for (size_t ci = 0; ci < cases.size(); ++ci) SummaryTable(body, cases[ci], results[ci], jobs);
    body += "\n## Every row, mesh by mesh\n";
    for (const std::string& d : details) body += d;
  }

  if (opt.paper) PaperSection(body, mesh_dir, opt.paper_iterations);
  if (opt.scans) {
    const std::vector<Job> scan_jobs =
        MakeJobs({"bilateral_normal", "guided_normal"}, !opt.scan_oracles, opt.jobs, opt.oracle_jobs);
    ScanSection(body, opt.scan, scan_jobs, mesh_dir, opt.shared / "data" / "real");
  }

  const double wall = Seconds(start, Clock::now());
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, 0);
  if (errno == 0 && nice > 0) command.insert(command.begin(), {"nice", "-n", absl::StrCat(nice)});
  double load = std::nan("");
  if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%*f %*f %lf", &load) != 1) load = std::nan("");
    std::fclose(f);
  }
  // A run of the scan cases alone is docs/quality-scans.md.
  const bool scans_only = opt.meshes.empty() && !opt.paper;
  std::printf(
      "# Smoothing quality%s\n\nGenerated by `%s > docs/%s` (bench/quality.cc) on %s, %u CPUs; "
      "wall time %.1f min; the machine's load average over the 15 minutes before it ended was %.1f (times "
      "grow with other work on the machine).\n",
      scans_only ? " on scans" : "", absl::StrJoin(command, " ").c_str(),
      scans_only ? "quality-scans.md" : "quality.md", CpuModel().c_str(), std::thread::hardware_concurrency(),
      wall / 60.0, load);
  std::fputs(kMethodPointer, stdout);
  if (opt.policy_changed) {
    std::printf(
        "\n**An ablation**: the default job ran with `--policy` above, not with today's policy "
        "(core/job/policy.h).\n");
  }
  std::fputs(body.c_str(), stdout);
  return 0;
}
