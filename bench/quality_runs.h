// The quality benchmark's runs: jobs (the default job, every flow's oracle sweep over iteration
// counts, and JobSpecs from the command line) on the noisy copies of a mesh, measured against
// the clean mesh, and their means over the seeds.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "core/flows/flow.h"
#include "core/job/policy.h"
#include "core/measure/evaluation.h"
#include "core/mesh.h"
#include "meshsmooth/v1/smoothing.pb.h"

namespace meshsmooth::bench {

// Iteration counts the oracle tries, about x1.6 apart.
inline const std::vector<int> kOracleCounts = {1, 2, 3, 5, 8, 12, 20, 32, 50, 80, 125, 200, 320, 500, 800, 1250, 2000};

// A job as rows name it: a label and the spec the service would get.
struct Job {
  std::string label;
  v1::JobSpec spec;
  bool oracle = false;  // swept over kOracleCounts
};

// One run of a job on one noisy mesh.
struct Run {
  absl::Status status;
  Quality q;
  double seconds = 0.0;
  int iterations = 0;    // run by the flow
  double noise_h = 0.0;  // automatic stopping: the input's noise estimate, in h
  std::string stop;      // why the flow stopped (StopReasonName)
};

// A row of a table: the runs of one job (one per seed) at one iteration count.
struct Row {
  std::string label;
  int iterations = 0;  // 0: not a sweep (the noisy input, or a job's own count)
  std::vector<Run> runs;
};

// The rows of one mesh in one noise case.
struct MeshCase {
  std::string mesh;
  Row noisy;
  std::vector<Row> rows;  // rows[0] is the default job
};

// One noisy input of a row: the mesh, its topology, and the measure of a result against the
// clean surface (GroundTruth::Evaluate for a noisy copy of the clean mesh; a measure against the
// clean surface for a scan, which has connectivity of its own).
struct Input {
  const Mesh* mesh = nullptr;
  const Topology* topology = nullptr;
  std::function<absl::StatusOr<Quality>(const Mesh&)> evaluate;
};

// The noisy copies `noisy` of `truth`'s mesh as inputs (both must outlive them).
std::vector<Input> CopiesOf(const GroundTruth& truth, const std::vector<Mesh>& noisy);

// The policy every run of this process's default job takes (job::kPolicy unless --policy
// changed it: an ablation).
void SetJobPolicy(const job::JobPolicy& policy);

// The rows of the two normal filters as their authors' reference code runs by default, the
// figures the denoising literature's tables report: one iteration of 20 filter passes (sigma_s
// 1, the mean distance between the centroids of edge-adjacent faces; sigma_r 0.35) and 10
// vertex updates, bilateral_normal for BNF (Zheng et al. 2011) and guided_normal for GNF (Zhang
// et al. 2015).
inline constexpr char kBnfLabel[] = "BNF, authors' defaults";
inline constexpr char kGnfLabel[] = "GNF, authors' defaults";

// The rows of a run, in order: the default job, the authors' BNF and GNF, an oracle row for
// each flow of the flow table in `flows` (all when empty, none when `no_flows`), then `jobs` as
// given and `oracle_jobs` swept (JobSpecs in protobuf text format). Exits with status 2 on a
// spec that does not parse or that the service would refuse.
std::vector<Job> MakeJobs(const std::vector<std::string>& flows, bool no_flows, const std::vector<std::string>& jobs,
                          const std::vector<std::string>& oracle_jobs);

// The row labelled `label` of `mc` (e.g. kBnfLabel), or null.
const Row* FindRow(const MeshCase& mc, const std::string& label);

// The flow parameters the service's FromProto makes of `spec`; exits with status 2 on a spec
// it refuses.
FlowParams ParamsOf(const v1::JobSpec& spec);

// The measures of the inputs themselves (one run per input), labelled `label`.
Row InputRow(const std::string& label, const std::vector<Input>& inputs);

// `p` run on each of `inputs`, as row `label` at `iterations` (0: not a sweep).
Row RunRow(const std::string& label, int iterations, const std::vector<Input>& inputs, const FlowParams& p);

// How an oracle sweeps: the counts it tries (increasing), and how many counts past the best so
// far it tries before it stops (the error of every flow here falls, then rises).
struct Sweep {
  std::vector<int> counts = kOracleCounts;
  int past_best = 2;
};

// The oracle: `job` at each count of the sweep, keeping the count with the smallest mean RMS
// distance over the seeds; it stops `past_best` counts after the best so far and at the first
// count that fails on any seed. Each count runs from the input, so a sweep costs the sum of
// the counts it tries.
Row OracleRow(const Job& job, const std::vector<Input>& inputs, const Sweep& sweep = {});

// Each job of `jobs` on `inputs`: its oracle sweep or its run as given.
std::vector<Row> JobRows(const std::vector<Job>& jobs, const std::vector<Input>& inputs, const Sweep& sweep = {});

// Whether every run of `row` succeeded with finite positions (false for no runs).
bool AllOk(const Row& row);

// Mean over the runs that succeeded (NaN where none did, or where a figure is NaN); their
// count and mean time go to `ok` and `seconds` when given.
Quality MeanQuality(const Row& row, int* ok = nullptr, double* seconds = nullptr);

// The oracle row of `mc` (its jobs are `jobs`) with the smallest mean RMS distance; nullptr
// when every one failed.
const Row* BestOracle(const MeshCase& mc, const std::vector<Job>& jobs);

}  // namespace meshsmooth::bench
