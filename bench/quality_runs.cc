#include "bench/quality_runs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "absl/strings/str_cat.h"
#include "bench/bench_common.h"
#include "core/flows/flow_table.h"
#include "core/job/default_job.h"
#include "google/protobuf/text_format.h"
#include "server/convert.h"

namespace meshsmooth::bench {
namespace {

job::JobPolicy job_policy = job::kPolicy;

Run RunJob(const Input& input, const FlowParams& p) {
  Run run;
  Mesh m = *input.mesh;
  Topology topo = *input.topology;  // lent to the job (Smooth()), which may renumber it meanwhile
  const Clock::time_point t0 = Clock::now();
  absl::StatusOr<FlowResult> r = job::SmoothWithPolicy(m, topo, p, {}, job_policy);
  run.seconds = Seconds(t0, Clock::now());
  if (!r.ok()) {
    run.status = r.status();
    return run;
  }
  run.iterations = r->iterations_run;
  run.stop = std::string(StopReasonName(r->stop_reason));
  if (r->auto_stop) run.noise_h = r->auto_stop->noise_sigma_h;
  absl::StatusOr<Quality> q = input.evaluate(m);
  run.status = q.status();
  if (q.ok()) run.q = *q;
  return run;
}

}  // namespace

void SetJobPolicy(const job::JobPolicy& policy) { job_policy = policy; }

std::vector<Input> CopiesOf(const GroundTruth& truth, const std::vector<Mesh>& noisy) {
  std::vector<Input> inputs;
  for (const Mesh& m : noisy) {
    inputs.push_back({&m, &truth.topology(), [&truth](const Mesh& result) { return truth.Evaluate(result); }});
  }
  return inputs;
}

std::vector<Job> MakeJobs(const std::vector<std::string>& flows, bool no_flows, const std::vector<std::string>& jobs,
                          const std::vector<std::string>& oracle_jobs) {
  std::vector<Job> out = {{"default job", v1::JobSpec(), false}};
  for (const auto& [label, flow] : {std::pair{kBnfLabel, "bilateral_normal"}, std::pair{kGnfLabel, "guided_normal"}}) {
    Job j{label, v1::JobSpec(), false};
    j.spec.set_flow(flow);
    j.spec.set_iterations(1);
    v1::NormalFilter* f = j.spec.mutable_normal_filter();
    f->set_normal_iterations(20);
    f->set_vertex_iterations(10);
    f->set_sigma_spatial(1.0);
    f->set_sigma_range(0.35);
    out.push_back(j);
  }
  for (const FlowRow& flow : FlowTable()) {
    if (no_flows) break;
    if (!flows.empty() && std::find(flows.begin(), flows.end(), flow.name) == flows.end()) continue;
    Job j{std::string(flow.name), v1::JobSpec(), true};
    j.spec.set_flow(std::string(flow.name));
    out.push_back(j);
  }
  auto parse = [](const std::string& text, bool oracle) {
    Job j{absl::StrCat("`", text, "`"), v1::JobSpec(), oracle};
    if (!google::protobuf::TextFormat::ParseFromString(text, &j.spec)) {
      std::fprintf(stderr, "cannot parse the JobSpec {%s}\n", text.c_str());
      std::exit(2);
    }
    ParamsOf(j.spec);  // refuses a bad spec before any work
    return j;
  };
  for (const std::string& t : jobs) out.push_back(parse(t, false));
  for (const std::string& t : oracle_jobs) out.push_back(parse(t, true));
  return out;
}

FlowParams ParamsOf(const v1::JobSpec& spec) {
  absl::StatusOr<server::JobParams> params = server::FromProto(spec, kMaxIterations);
  if (!params.ok()) {
    std::fprintf(stderr, "bad job spec {%s}: %s\n", spec.ShortDebugString().c_str(),
                 params.status().ToString().c_str());
    std::exit(2);
  }
  return params->flow;
}

Row InputRow(const std::string& label, const std::vector<Input>& inputs) {
  Row row{label, 0, {}};
  for (const Input& in : inputs) {
    Run r;
    absl::StatusOr<Quality> q = in.evaluate(*in.mesh);
    r.status = q.status();
    if (q.ok()) r.q = *q;
    row.runs.push_back(r);
  }
  return row;
}

Row RunRow(const std::string& label, int iterations, const std::vector<Input>& inputs, const FlowParams& p) {
  Row row{label, iterations, {}};
  for (const Input& in : inputs) row.runs.push_back(RunJob(in, p));
  return row;
}

std::vector<Row> JobRows(const std::vector<Job>& jobs, const std::vector<Input>& inputs, const Sweep& sweep) {
  std::vector<Row> rows;
  for (const Job& job : jobs) {
    rows.push_back(job.oracle ? OracleRow(job, inputs, sweep)
                              : RunRow(job.label, static_cast<int>(job.spec.iterations()), inputs, ParamsOf(job.spec)));
  }
  return rows;
}

Row OracleRow(const Job& job, const std::vector<Input>& inputs, const Sweep& sweep) {
  Row best;
  double best_rms = HUGE_VAL;
  int worse = 0;
  for (int count : sweep.counts) {
    v1::JobSpec spec = job.spec;
    spec.set_iterations(static_cast<uint32_t>(count));
    Row row = RunRow(job.label, count, inputs, ParamsOf(spec));
    if (!AllOk(row)) {
      if (best.runs.empty()) best = std::move(row);
      break;
    }
    const double rms = MeanQuality(row).rms_distance;
    if (rms < best_rms) {
      best_rms = rms;
      best = std::move(row);
      worse = 0;
    } else if (++worse >= sweep.past_best) {
      break;
    }
  }
  return best;
}

bool AllOk(const Row& row) {
  for (const Run& r : row.runs) {
    if (!r.status.ok() || r.q.non_finite_vertices > 0) return false;
  }
  return !row.runs.empty();
}

Quality MeanQuality(const Row& row, int* ok, double* seconds) {
  Quality m;
  double flipped = 0.0, flipped_fine = 0.0, secs = 0.0;
  int n = 0;
  for (const Run& r : row.runs) {
    if (!r.status.ok()) continue;
    m.rms_distance += r.q.rms_distance;
    m.max_distance += r.q.max_distance;
    m.normal_error_deg += r.q.normal_error_deg;
    m.crease_normal_error_deg += r.q.crease_normal_error_deg;
    m.volume_change_percent += r.q.volume_change_percent;
    flipped += static_cast<double>(r.q.flipped_faces);
    flipped_fine += static_cast<double>(r.q.flipped_in_fine_detail);
    m.edge_length_cv += r.q.edge_length_cv;
    m.min_angle_deg += r.q.min_angle_deg;
    m.non_finite_vertices += r.q.non_finite_vertices;
    secs += r.seconds;
    ++n;
  }
  const double k = n > 0 ? 1.0 / n : std::nan("");
  m.rms_distance *= k;
  m.max_distance *= k;
  m.normal_error_deg *= k;
  m.crease_normal_error_deg *= k;
  m.volume_change_percent *= k;
  m.flipped_faces = n > 0 ? std::llround(flipped * k) : 0;
  m.flipped_in_fine_detail = n > 0 ? std::llround(flipped_fine * k) : 0;
  m.edge_length_cv *= k;
  m.min_angle_deg *= k;
  if (seconds != nullptr) *seconds = secs * k;
  if (ok != nullptr) *ok = n;
  return m;
}

const Row* FindRow(const MeshCase& mc, const std::string& label) {
  for (const Row& row : mc.rows) {
    if (row.label == label) return &row;
  }
  return nullptr;
}

const Row* BestOracle(const MeshCase& mc, const std::vector<Job>& jobs) {
  const Row* best = nullptr;
  double best_rms = HUGE_VAL;
  for (size_t i = 0; i < mc.rows.size(); ++i) {
    if (!jobs[i].oracle || !AllOk(mc.rows[i])) continue;
    const double rms = MeanQuality(mc.rows[i]).rms_distance;
    if (rms < best_rms) {
      best_rms = rms;
      best = &mc.rows[i];
    }
  }
  return best;
}

}  // namespace meshsmooth::bench
