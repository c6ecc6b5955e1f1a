// The quality benchmark: the mesh-denoising literature's protocol on the real meshes clean
// enough to serve as ground truth and on the synthetic shapes. Each clean mesh gets Gaussian
// noise along its vertex normals (sigma = 0, 0.1, 0.2, 0.3 of its mean edge length h, several
// seeds) and in random directions; then the default job (a default JobSpec through the
// service's FromProto), every flow of the flow table at its best iteration count ("oracle"),
// and any job given on the command line run on it, and core/measure/evaluation.h measures each result
// against the clean mesh. Markdown to stdout; docs/quality.md is its output:
//   nice -n 10 build/bench/meshsmooth_quality > docs/quality.md
// `--help` lists the options; `--quick` runs a subset in well under a minute.
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
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "base/huge_pages.h"
#include "bench/bench_common.h"
#include "bench/quality_inputs.h"
#include "bench/quality_paper.h"
#include "bench/quality_runs.h"
#include "bench/quality_tables.h"
#include "core/flows/flow.h"
#include "core/io/mesh_io.h"
#include "core/measure/evaluation.h"

namespace meshsmooth::bench {
namespace {

// What the command line asks for (kUsage).
struct Options {
  std::filesystem::path shared = std::filesystem::path(MESHSMOOTH_SOURCE_DIR) / ".." / "shared";
  std::vector<std::string> meshes = kDefaultMeshes;
  std::vector<double> sigmas = {0.0, 0.1, 0.2, 0.3};
  std::vector<double> random_sigmas = {0.1, 0.2, 0.3};
  int seeds = 3;
  int large_seeds = 1;             // 0: as many as `seeds`
  std::vector<std::string> flows;  // empty: every flow of the table, unless no_flows
  bool no_flows = false;
  std::vector<std::string> jobs, oracle_jobs;  // JobSpecs in protobuf text format
  bool paper = true;
  int paper_iterations = 20;
};

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

constexpr char kHowToRead[] = R"(
## How to read

**Protocol.** Each clean mesh gets Gaussian noise along its area-weighted vertex normals with a
standard deviation of sigma x h (h: the clean mesh's mean edge length), one noisy copy per seed,
and Gaussian noise of the same size in random directions (`AddNormalNoise`,
`AddRandomDirectionNoise` in core/shapes/added_noise.h: seeded, the same bytes on every machine). sigma = 0
is the clean mesh itself: a job should give it back unchanged. Every figure is the mean over the
seeds (the "Inputs" table gives their number per mesh).

**Measures** (core/measure/evaluation.h), each against the clean mesh:
- *RMS / max dist*: distance from each vertex of the result to the clean *surface* (exact
  point-to-triangle distance over all its triangles), in h. Vertex-to-vertex distance would
  punish the tangential regularisation the paper wants; this does not.
- *normal err*: mean angle in degrees between each face's normal and the same face's clean
  normal (faces of zero area in either mesh are skipped); *crease normal err*: the same over the
  faces with an edge whose clean dihedral angle (between the two faces' normals) is above 30
  degrees ("crease faces" in the Inputs table; — where there are none).
- *volume*: change of the enclosed volume in %, closed meshes only (— for open ones).
- *flipped*: faces whose normal points against the clean one (dot product < 0), among the faces
  that are not folded in the clean mesh ("folded faces" in the Inputs table: across one of their
  edges the other face's normal points more than 90 degrees away). A scan's folds are defects a
  smoothing should remove; unfolding one would otherwise count as turning it over. In brackets:
  how many of them lie in fine detail ("fine-detail faces" in the Inputs table: the clean
  area-weighted normals at two of the face's corners are more than 20 degrees apart, a turn at
  the scale of the sampling as large as the one noise of 0.1-0.2 h gives a face).
- *edge CV*, *min angle*: the paper's regularity (edge-length coefficient of variation, smallest
  triangle angle), as core/measure/metrics.h computes them.
- *time*: wall time of `Smooth()` alone (not the evaluation), on all threads, mean over seeds.
- *status*: ok, or how many seeds failed and the first error, as the service would report it.

**Rows.**
- *noisy input* (*clean input* at sigma = 0): the measures of the input itself, the reference
  every ratio (×) is taken against.
- *default job*: what a user gets without parameters (`meshsmooth smooth IN -o OUT`): a default
  `meshsmooth.v1.JobSpec` through the service's `FromProto` (server/convert.cc), then `Smooth()`:
  `bilaplacian` or `bilateral_normal`, whichever the estimated error prefers, with automatic
  stopping (its iterations, stop reason and noise estimate are in the summary tables; "How the
  defaults were chosen" below). Unlike the service, the benchmark neither rounds the input to float32 (Draco) nor welds
  coincident vertices (only the clean dragon has any).
- one row per flow of the flow table, with its default parameters (a JobSpec naming only the
  flow), at its best iteration count (the *oracle*): the counts 1, 2, 3, 5, 8, 12, 20, 32, 50,
  80, 125, 200, 320, 500, 800, 1250, 2000 are tried in turn and the one with the smallest mean
  RMS distance is kept (at 2000 the best may lie beyond); the sweep stops two counts past the
  best and at the first count that fails on any seed.
  A flow added to the table gets its row by itself; `--job` and `--oracle-job` add rows for any
  JobSpec.

**Summary tables.** For each noise case and mesh: the noisy input, the default job with its ratios
to the noisy input (×; below 1 is better), its iterations (mean over the seeds), why its first seed
stopped and its noise estimate (mean, in h), and the oracle row with the smallest RMS distance, with
the default job's RMS distance over it ("default / best RMS"; 1 = the default is as good as the
best flow at its best count). *targets missed* lists what the default job falls short of among
the targets it is held to: at sigma >= 0.2 an RMS distance and a normal error at most 0.6× the
noisy input's, at sigma = 0.1 at most 0.9×; on the clean input an RMS distance within 0.02 h and a
normal error within 2 degrees; at every sigma a volume change within ±1% (closed meshes), no
flipped face on any seed, no failure or NaN, and an RMS distance within 1.25× the best oracle
row's.

**Meshes.** Every mesh of `../shared/data/meshes` except `beetle.obj`: a coarse hand-measured
model, not a scan, with 47 edges of more than two faces, 23 holes and two components; its
non-manifold vertices stay fixed in every flow, so it measures nothing about denoising. The
others are manifold with consistent orientation. The Stanford bunny has 1,113 unreferenced
vertices (no noise, not measured) and five holes; the dragon is a raw scan (151 components, 407
holes, 367 zero-area faces, whose normal error is not measured). Then the synthetic icosphere
(level 4) and the paper's two-rate torus, and three shapes of kinds the real meshes lack (core/shapes/,
bench/quality.cc `LoadSubject`): iso-surface output, a tilted torus (`mt-torus`) and a capped
cylinder (`mt-cylinder`, a machined part with sharp rims) through marching tetrahedra, with
valences from 3 up, needles and slivers (smallest angles under 0.1°); and an icosphere of
level 5 with 60 round holes (`holey-sphere`): 11% of its vertices on a rim, 42% within two rings of a
rim. The dragon gets one seed: over 437k vertices another
seed moves its figures by about 0.1% (the relative standard error of an RMS over N samples is
near 1/sqrt(2N)), and each of its seeds adds several minutes to the run.

## How the defaults were chosen

- **Automatic stopping** (core/measure/noise.h, core/flows/auto_stop.h). The noise estimate reads
  Gaussian noise along the normals within a few percent on every mesh (the default job's column
  in the summary tables against the sigma of the case) and 0.00–0.04 h on the clean meshes,
  where the cubic fit cannot follow coarse, strongly curved regions; that much is removed in
  quadrature, and below 0.02 h the job does nothing: every clean input comes back unchanged
  (the sigma = 0 table). Otherwise the run returns the iteration with the least estimated mean
  squared distance to the noise-free surface: Stein's unbiased risk estimate, its divergence
  from a probe copy of the input moved by ±0.05 sigma along the normals and run beside the job
  (Monte-Carlo SURE, Ramani, Blu, Unser 2008), sigma the root mean square of the fit residuals
  within three robust scales, taken 10% high. The same figure tells flows apart, so it needs no
  constant per flow. Over the 35 noisy cases of fandisk, bunny-small, max-planck, camelhead,
  turbine, sphere and two-rate-torus at sigma = 0.1, 0.2, 0.3 and random sigma = 0.1, 0.3 the
  default job's RMS distance is 0.96–2.08× the best oracle row's in the summary tables, mean
  1.14, above 1.25× only on the sphere, whose best row is bilateral_normal at 2000 iterations
  (the discrepancy principle it replaces, stopping once the vertices had moved as far as the
  noise, measured over the same cases on three seeds: 1.00–3.95×, mean 1.70).
  Tried: the discrepancy principle at factors 0.85 and 1 (bilaplacian; mean 1.99 / 1.78 over
  those cases) and 0.6 / 0.75 / 0.9 for bilateral_normal (2.61 / 2.16 / 1.82: its displacement
  does not track the noise it removes); SURE with sigma not taken high (`kRiskSigmaMargin` 1 in
  auto_stop.h): the robust scale reads noise in random directions low, and the torus at random
  sigma = 0.2 stops bilateral_normal at 4 iterations, 1.7× its best count's distance (20
  iterations with the margin); SURE on the robust scale less the floor: random sigma = 0.2 stops
  after 1–3 iterations on the sphere, the torus, camelhead and turbine; the root mean square less
  the floor: random sigma = 0.1 stops after one iteration on four meshes: all dropped.
- **Flow: chosen per mesh** between `bilaplacian` and `bilateral_normal` by that estimate (a
  JobSpec that names no flow, no count and no step; `--flow auto`, the CLI's default). At their
  best counts `bilaplacian` is the best flow, or within 1.1× of it, on every scan, and
  `bilateral_normal` on the CAD parts (fandisk, turbine; within 1.02× of the best with creases
  kept) and the smooth synthetic shapes; each is up to 2× (bilaplacian on CAD) or 1.3×
  (bilateral on scans) off where the other wins. The estimate picks the better one in most
  cases; the misses cost 1.1–1.65× (sphere and torus at sigma = 0.3 pick bilaplacian).
  Tried: `guided_normal` as a third candidate (same 35 cases, one seed): turbine 0.092 → 0.090 h
  at sigma = 0.2, 0.123 → 0.122 at 0.3, but fandisk 0.056 → 0.061 and camelhead at random
  sigma = 0.3 0.050 → 0.060 h with 34 → 116 flipped faces, for a third run per job: dropped.
  Tried on the iso-surface meshes, where the estimate picks `bilateral_normal` in cases that
  `bilaplacian` does better (the marching-tetrahedra torus at sigma = 0.1: 0.0274 h and 8
  flipped faces against 0.0240 h and none, edge CV 0.56 against 0.25): keeping
  bilaplacian unless bilateral_normal's estimate is lower by 0.05 sigma^2 (over 60 cases: the
  torus 45 → 37 flipped faces, nefertiti 22 → 10, but the sphere up to 1.26× and the two-rate
  torus up to 1.23× worse); the estimate's offsets taken along normals averaged over the 1-ring,
  so that tangential moves on an irregular mesh count less (two-rate torus at sigma = 0.2 0.059
  → 0.046 h, but nefertiti at sigma = 0.1 0.047 → 0.052 h with 1 → 11 flipped faces): dropped.
  The tangential moves are the likely cause: the estimate measures offsets along the noisy
  input's normals, which tilt on slivers, so bilaplacian's regularising moves read partly as
  error.
  Meshes above 100,000 vertices choose flow and count on eight breadth-first patches of 20,000
  vertices in all and run once: the two candidates with their probes would cost several times
  the run (the noisy dragon's default job: 45 iterations, 1.4 s through the service, against
  3.5 s with the probe on the whole mesh; `meshsmooth_bench --default-job-only`). `median` (the
  former default, 20 iterations, step 0.1 h^2) moved clean meshes by 0.15–0.38 h and lost up to
  16% of the volume: dropped.
- **Volume.** On a closed mesh the automatic job moves the free vertices along their normals
  by the common distance that gives back the input's enclosed volume (auto_stop.h): turbine at
  sigma = 0.2, 8 iterations, -4.56% without it, -0.65% with it (the noisy input itself is -0.65%
  from the clean part).
- **Fold repair, within 0.2 h.** After the run the free vertices of edges whose two faces meet
  at more than 120° move half-way to their ring's centroid, a few rounds, and no vertex further
  than 0.2 h in all (`kFoldRepairReachH`, auto_stop.h). Unbounded, the repair flattened the
  turbine's strips narrower than the noise, whose faces also meet at more than 120° after a run:
  at sigma = 0.1 / 0.2 / 0.3 RMS 0.061 / 0.092 / 0.123 h and 72 / 141 / 188 flipped faces,
  against 0.052 / 0.081 / 0.113 h and 41 / 110 / 166 within the bound (0.051 / 0.079 / 0.112 h
  and 37 / 113 / 185 without any repair). The dragon keeps the repair's gain along the normals
  (sigma = 0.2: 871 flipped faces, 927 without the repair) and half of it at random sigma = 0.3
  (2,149; 1,763 unbounded, 2,652 without). Tried: bounds of 0.1 / 0.3 h (dragon at random
  sigma = 0.3: 2,360 / 2,000 flipped; turbine at sigma = 0.2: 0.080 / 0.082 h); moving only the
  tangential part of the step (turbine at sigma = 0.2: 185 flipped); repairing only folds with a
  face under 10% / 25% of its ring's mean (dragon at random sigma = 0.3: 2,490 / 2,225); the
  fold angle at 90° or 100° instead of 120° (`kFoldAngleDeg`; unbounded repair): camelhead at
  sigma = 0.1 ends with 10 / 7 flipped faces instead of 5, and at 90° fandisk's normal error goes
  1.28° → 2.30° (its creases read as folds): all dropped.
- **What still flips.** Every flow at every count leaves flipped faces on the scans with
  needles and on the turbine (the tables mesh by mesh: on the dragon at sigma = 0.2 the flows'
  best counts leave 742 to 3,112). They lie where the noise hides the surface: most in fine
  detail (the brackets: the dragon's default job at sigma = 0.2 684 of 871, the turbine's 75 of
  110), the turbine's others on strips about 0.25 h wide between right-angled creases, narrower
  than the noise. On the dragon 783 of 882 flipped faces (a numpy count on the same noisy copy)
  touch a boundary vertex, which stays fixed and keeps its noise; moving the boundary vertices
  along their interior neighbours' mean normal on to those neighbours' mean (three passes, a
  prototype) left 882: the noise along a rim's tilted normals moves its vertices sideways too.
  On the iso-surface meshes the flips sit on the extraction's slivers, which
  `bilateral_normal` keeps (smallest angle 0.02° after a run) while `bilaplacian` evens them out
  and flips none. Tried: tangential relaxation in bilateral_normal's vertex update (0.3 of the
  umbrella on vertices whose filtered normals agree within 10°), on an earlier extraction of the
  torus: edge CV 0.57 → 0.28, but 6 → 10 flipped faces at sigma = 0.1, 53 → 75 at random
  sigma = 0.3, and automatic stopping ended earlier (sigma = 0.3: 0.048 → 0.062 h): dropped.
- **Boundary: fixed.** Smoothing boundary loops as curves by default was tried: camelhead at
  sigma = 0.2 ends at RMS 0.125 h (max 1.9 h) against 0.055 h with fixed boundaries, the loop
  shrinking inwards over the run: dropped.
)";

constexpr char kUsage[] =
    "usage: meshsmooth_quality [--meshes a,b,...] [--sigmas 0,0.1,0.2,0.3] [--random-sigmas 0.1,0.2,0.3]\n"
    "                          [--seeds 3] [--large-seeds 1] [--flows a,b,...] [--job SPEC]... [--oracle-job SPEC]...\n"
    "                          [--shared DIR] [--paper-iterations 20] [--no-paper] [--quick]\n"
    "  --meshes         real meshes by file name without extension, and `sphere`, `two-rate-torus`,\n"
    "                   `mt-torus`, `mt-cylinder`, `holey-sphere`\n"
    "  --sigmas         Gaussian noise along the normals, in mean edge lengths h (0 = the clean mesh)\n"
    "  --random-sigmas  Gaussian noise in random directions (\"\": none)\n"
    "  --seeds          noisy copies per mesh and sigma; --large-seeds for meshes of 200k+ vertices\n"
    "                   (default 1; 0: as --seeds)\n"
    "  --flows          oracle rows for these flows of the flow table (default: all; `none`: none)\n"
    "  --job SPEC       one more row: a meshsmooth.v1.JobSpec in protobuf text format, run as given,\n"
    "                   e.g. --job 'flow: \"median\" iterations: 5 boundary: BOUNDARY_MODE_CURVE'\n"
    "  --oracle-job SPEC  the same, swept over iteration counts like the flows' rows\n"
    "  --shared DIR     the folder holding data/meshes (default: ../shared beside the source tree)\n"
    "  --no-paper       skip the fixed-iteration tables of the paper's setting\n"
    "  --quick          fandisk, bunny-small and the sphere, sigma 0 and 0.2 (random: 0.2), one seed,\n"
    "                   no paper tables\n"
    "  --write-noisy MESH SIGMA SEED OUT  only write the benchmark's input for MESH with Gaussian noise\n"
    "                   of SIGMA h along the normals and SEED (as the tables use it) to OUT, and exit\n";

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) {
  meshsmooth::UseHugePagesForLargeBuffers(argv);  // first: may re-execute the program
  using namespace meshsmooth;
  using namespace meshsmooth::bench;
  const Clock::time_point start = Clock::now();
  Options opt;
  std::vector<std::string> command = {"build/bench/meshsmooth_quality"};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    command.push_back(a.find(' ') == std::string::npos ? a : "'" + a + "'");
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fputs(kUsage, stderr);
        std::exit(2);
      }
      command.push_back(std::string(argv[i + 1]).find(' ') == std::string::npos ? argv[i + 1]
                                                                                : "'" + std::string(argv[i + 1]) + "'");
      return argv[++i];
    };
    if (a == "--meshes") {
      opt.meshes = absl::StrSplit(next(), ',', absl::SkipEmpty());
    } else if (a == "--sigmas") {
      opt.sigmas = ParseDoubles(next());
    } else if (a == "--random-sigmas") {
      opt.random_sigmas = ParseDoubles(next());
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
      const Mesh noisy = MakeNoisy(subject->truth->mesh(), Case{Noise::kNormal, std::atof(sigma.c_str())},
                                   std::strtoull(seed.c_str(), nullptr, 10));
      if (absl::Status s = WriteMesh(out, noisy); !s.ok()) {
        std::fprintf(stderr, "meshsmooth_quality: %s\n", s.ToString().c_str());
        return 1;
      }
      return 0;
    } else if (a == "--quick") {
      opt.meshes = {"fandisk", "bunny-small", "sphere"};
      opt.sigmas = {0.0, 0.2};
      opt.random_sigmas = {0.2};
      opt.seeds = 1;
      opt.paper = false;
    } else {
      std::fputs(kUsage, stderr);
      return a == "--help" ? 0 : 2;
    }
  }
  const std::vector<Job> jobs = MakeJobs(opt.flows, opt.no_flows, opt.jobs, opt.oracle_jobs);
  const std::vector<Case> cases = MakeCases(opt.sigmas, opt.random_sigmas);
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
      for (int s = 1; s <= n; ++s) noisy.push_back(MakeNoisy(truth.mesh(), c, static_cast<uint64_t>(s)));
      MeshCase mc{name, InputRow(c.sigma == 0.0 ? "clean input" : "noisy input", truth, noisy), {}};
      if (c.sigma > 0.0 && eval_seconds == 0.0) eval_seconds = OneThreadEvaluationSeconds(truth, noisy[0]);
      for (const Job& job : jobs) {
        mc.rows.push_back(job.oracle ? OracleRow(job, truth, noisy)
                                     : RunRow(job.label, job.spec.iterations(), truth, noisy, ParamsOf(job.spec)));
      }
      DetailTable(detail, c, mc, n);
      results[ci].push_back(std::move(mc));
      std::fprintf(stderr, "%s, %s: done at %.0f s\n", name.c_str(), c.Name().c_str(), Seconds(start, Clock::now()));
    }
    details.push_back(detail);
    InputsRow(inputs, *subject, seeds, eval_seconds);
  }

  InputsTable(body, inputs);
  body += "\n## Summary: the default job against the noisy input and the best oracle row\n";
  for (size_t ci = 0; ci < cases.size(); ++ci) SummaryTable(body, cases[ci], results[ci], jobs);
  body += "\n## Every row, mesh by mesh\n";
  for (const std::string& d : details) body += d;

  if (opt.paper) PaperSection(body, mesh_dir, opt.paper_iterations);

  const double wall = Seconds(start, Clock::now());
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, 0);
  if (errno == 0 && nice > 0) command.insert(command.begin(), {"nice", "-n", absl::StrCat(nice)});
  double load = std::nan("");
  if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%*f %*f %lf", &load) != 1) load = std::nan("");
    std::fclose(f);
  }
  std::printf(
      "# Smoothing quality\n\nGenerated by `%s > docs/quality.md` (bench/quality.cc) on %s, %u CPUs; "
      "wall time %.1f min; the machine's load average over the 15 minutes before it ended was %.1f (times "
      "grow with other work on the machine).\n",
      absl::StrJoin(command, " ").c_str(), CpuModel().c_str(), std::thread::hardware_concurrency(), wall / 60.0, load);
  std::fputs(kHowToRead, stdout);
  std::fputs(body.c_str(), stdout);
  return 0;
}
