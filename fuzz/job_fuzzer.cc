// libFuzzer target: the service's whole job path, without the network.
//
// The input's head picks a JobSpec (job_input.h), which goes through the server's own
// conversion and checks (server::FromProto); the rest is the Draco upload, which a
// server::SmoothJob runs as a worker does: decode, weld, validate, a few iterations of the
// flow, ridges and ravines, encode in the chosen output encoding. The result is then decoded
// with Draco and checked; any violation aborts, so libFuzzer keeps the input:
//   - the job ends with exactly one of a result (after `accepted`) or an error status;
//   - the result decodes, and carries the feature attributes when they were asked for;
//   - sequential output keeps every point (the upload's count) and points welded together in
//     the upload still share one position; Edgebreaker output has at most the upload's
//     welded vertex count (it drops isolated vertices and splits non-manifold ones);
//   - every coordinate is finite and inside the upload's bounding box grown by what the flow may
//     move a vertex in the iterations it ran (ResultBound).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/flows/flow_table.h"
#include "core/io/draco_codec.h"
#include "core/weld.h"
#include "fuzz/job_input.h"
#include "server/admission.h"
#include "server/convert.h"
#include "server/options.h"
#include "server/smooth_job.h"

namespace meshsmooth::fuzz {
namespace {

// The spec of the input being run, printed with a violation.
const v1::JobSpec* current_spec = nullptr;

[[noreturn]] void Fail(const char* what) {
  std::fprintf(stderr, "fuzz_job: invariant violated: %s\nspec: %s\n", what,
               current_spec != nullptr ? current_spec->ShortDebugString().c_str() : "?");
  std::abort();
}

void Check(bool ok, const char* what) {
  if (!ok) Fail(what);
}

class RecordingSink : public server::JobSink {
 public:
  void OnAccepted(const v1::Accepted&) override { ++accepted; }
  void OnProgress(const v1::Progress&) override {}
  void OnResult(std::string draco_bytes, const v1::Summary& s) override {
    ++results;
    result = std::move(draco_bytes);
    summary = s;
  }
  void OnError(const absl::Status& s) override {
    ++errors;
    error = s;
  }

  int accepted = 0, results = 0, errors = 0;
  std::string result;
  v1::Summary summary;
  absl::Status error;
};

struct Box {
  Vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  Vec3 hi = -lo;
  void Add(const Vec3& p) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  // Grown on each side by `margin` per axis.
  Box Grown(const Vec3& margin) const { return {lo - margin, hi + margin}; }
  bool Contains(const Vec3& p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
};

// The box no vertex of the result may leave: the upload's, grown by what the flow that ran may
// move a vertex (its row's PassReach, flow_table.h), then by the quantization.
//   kConvex: every pass is a convex combination of neighbours (step <= 1): no growth.
//   kExtent: a pass moves a vertex by at most the current extent on each axis, so k passes grow
//     the box by (3^k - 1) / 2 extents on each side.
//   kMeanEdge: every step of a vertex is capped at h, the input's mean edge length, and
//     boundary curves move to a convex combination: k passes, k h.
//   quantized output: half a grid step (the largest extent / (2^bits - 1)) on each axis.
// Plus float32 rounding.
Box ResultBound(const Box& in, const server::JobParams& params, const v1::Summary& summary) {
  const Vec3 extent = in.hi - in.lo;
  const double h = summary.parameters().mean_edge_length();
  FlowParams ran = params.flow;
  ran.flow = ParseFlowName(summary.parameters().flow()).value();
  const int passes = static_cast<int>(summary.parameters().iterations_run()) * PassesPerIteration(ran);
  Vec3 margin;
  switch (FlowOf(*ran.flow).reach) {
    case PassReach::kConvex:
      break;
    case PassReach::kExtent:
      margin = extent * ((std::pow(3.0, passes) - 1.0) / 2.0);
      break;
    case PassReach::kMeanEdge:
      margin = Vec3{1, 1, 1} * (passes * h);
      break;
  }
  Box bound = in.Grown(margin);
  const Vec3 grown = bound.hi - bound.lo;
  const int bits = params.output.quantization_bits;
  const double step = bits > 0 ? std::max({grown.x, grown.y, grown.z}) / (std::ldexp(1.0, bits) - 1.0) : 0.0;
  const double magnitude = std::max({std::abs(bound.lo.x), std::abs(bound.lo.y), std::abs(bound.lo.z),
                                     std::abs(bound.hi.x), std::abs(bound.hi.y), std::abs(bound.hi.z)});
  return bound.Grown(Vec3{1, 1, 1} * (step / 2 + 1e-6 * magnitude));
}

// Exact equality with +0.0 == -0.0, as WeldPoints compares.
bool SamePosition(const Vec3& a, const Vec3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

void CheckResult(std::string_view upload, const server::JobParams& params, const RecordingSink& sink) {
  absl::StatusOr<Mesh> in = DecodeDraco(upload);
  Check(in.ok(), "the job succeeded on an upload that DecodeDraco refuses");
  absl::StatusOr<Mesh> out = DecodeDraco(sink.result);
  Check(out.ok(), "the result does not decode");
  const Welded in_welded = WeldPoints(in->positions);
  const Welded out_welded = WeldPoints(out->positions);

  if (params.output.method == DracoMethod::kSequential) {
    Check(out->positions.size() == in->positions.size(), "sequential output changed the point count");
    // Points welded into one vertex of the upload must still share one position.
    std::vector<size_t> first_point(in_welded.positions.size(), SIZE_MAX);
    for (size_t p = 0; p < in->positions.size(); ++p) {
      size_t& first = first_point[in_welded.point_to_vertex[p]];
      if (first == SIZE_MAX) first = p;
      Check(SamePosition(out->positions[p], out->positions[first]), "points welded in the upload came back apart");
    }
  }
  Check(out_welded.positions.size() <= in_welded.positions.size(), "the result has more vertices than the upload");

  Box box;
  for (const Vec3& p : in->positions) box.Add(p);
  const Box bound = ResultBound(box, params, sink.summary);
  for (const Vec3& p : out->positions) {
    Check(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z), "a result coordinate is not finite");
    if (!bound.Contains(p)) {
      std::fprintf(stderr,
                   "fuzz_job: vertex (%g, %g, %g) outside (%g, %g, %g) .. (%g, %g, %g), "
                   "upload's box (%g, %g, %g) .. (%g, %g, %g)\n",
                   p.x, p.y, p.z, bound.lo.x, bound.lo.y, bound.lo.z, bound.hi.x, bound.hi.y, bound.hi.z, box.lo.x,
                   box.lo.y, box.lo.z, box.hi.x, box.hi.y, box.hi.z);
      Fail("a result vertex lies outside what the flow may reach from the upload's box");
    }
  }

  if (params.detect_features) {
    for (const char* name : {"feature_label", "kmax", "kmin"}) {
      absl::StatusOr<std::vector<float>> values = DecodeDracoAttribute(sink.result, name);
      Check(values.ok() && values->size() == out->positions.size(), "a feature attribute is missing");
    }
  }
  const v1::EffectiveParameters& e = sink.summary.parameters();
  Check(e.iterations_run() <= e.iterations_requested(), "more iterations ran than were asked for");
}

}  // namespace
}  // namespace meshsmooth::fuzz

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // One core: the job's own threads stay at one (threads_per_job) and so does OpenMP.
  setenv("OMP_NUM_THREADS", "1", 0);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace meshsmooth;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const std::string_view head = bytes.substr(0, std::min(size, fuzz::kSpecBytes));
  const std::string_view upload = bytes.substr(head.size());

  server::ServerOptions options;  // the service's defaults, but quiet and on one thread
  options.threads_per_job = 1;
  options.log_jobs = false;
  // A vertex limit that keeps what the sizes an upload declares may cost inside run.sh's 2 GB
  // (the default, 20 million, admits a few GB); uploads of at most 72 KB hold far fewer.
  options.max_vertices = 1 << 20;
  const v1::JobSpec spec = fuzz::SpecFromBytes(head);
  fuzz::current_spec = &spec;
  absl::StatusOr<server::JobParams> params = server::FromProto(spec, options.max_iterations);
  if (!params.ok()) {
    fuzz::Check(params.status().code() == absl::StatusCode::kInvalidArgument, "a bad spec is not INVALID_ARGUMENT");
    return 0;
  }
  fuzz::RecordingSink sink;
  // The upload's bytes are held against a budget as a call holds them, and must all come back.
  server::MemoryBudget budget(int64_t{1} << 30);
  server::BudgetHold hold(&budget);
  fuzz::Check(hold.TryGrow(static_cast<int64_t>(upload.size())), "the budget refused a small upload");
  {
    server::SmoothJob job("fuzz", *params, std::string(upload), std::move(hold), server::Clock::now(), options, &sink);
    job.Run();
  }
  fuzz::Check(budget.held() == 0, "the job kept its upload's share of the memory budget");
  fuzz::Check(sink.results + sink.errors == 1, "the job did not end with exactly one result or error");
  if (sink.errors == 1) {
    fuzz::Check(!sink.error.ok() && sink.error.code() != absl::StatusCode::kInternal &&
                    sink.error.code() != absl::StatusCode::kUnknown,
                "the job failed without a clear status");
    return 0;
  }
  fuzz::Check(sink.accepted == 1, "a result came without 'accepted'");
  fuzz::CheckResult(upload, *params, sink);
  return 0;
}
