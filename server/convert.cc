#include "server/convert.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/io/formats.h"
#include "server/log.h"

namespace meshsmooth::server {
namespace {

// Proto3 keeps enum numbers it does not know (a newer client's, or garbage): InvalidArgument
// naming `field` and the values this server knows, rather than running them as the default.
absl::Status CheckEnum(const char* field, int value, const google::protobuf::EnumDescriptor* values) {
  if (values->FindValueByNumber(value) != nullptr) return absl::OkStatus();
  std::vector<std::string> names;
  for (int i = 0; i < values->value_count(); ++i) names.push_back(values->value(i)->name());
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": unknown value ", value, " (this server knows ", absl::StrJoin(names, ", "), ")"));
}

// JobSpec.enhance into `j.enhance`; InvalidArgument naming the field for a value out of range
// and for a smoothing field that does not apply to an enhancement job.
absl::Status EnhanceFromProto(const v1::JobSpec& spec, JobParams& j) {
  const v1::Enhancement& e = spec.enhance();
  if (absl::Status s = CheckEnum("enhance.method", e.method(), v1::EnhanceMethod_descriptor()); !s.ok()) return s;
  const std::pair<const char*, bool> smoothing_fields[] = {
      {"flow", !spec.flow().empty()},
      {"iterations", spec.iterations() != 0},
      {"step", spec.step() != 0.0},
      {"integration", spec.integration() != v1::INTEGRATION_EXPLICIT},
      {"theta", spec.has_theta()},
      {"adaptive", spec.adaptive().mode() != v1::ADAPTIVE_MODE_NONE},
      {"tolerance", spec.tolerance() != 0.0},
      {"max_displacement", spec.max_displacement() != 0.0},
      {"max_displacement_h", spec.max_displacement_h() != 0.0},
      {"boundary", spec.boundary() == v1::BOUNDARY_MODE_CURVE},
  };
  for (const auto& [field, set] : smoothing_fields) {
    if (set) {
      return absl::InvalidArgumentError(absl::StrCat(
          field,
          " does not apply to an enhancement job (enhance is set); leave it unset, or smooth in a job of its "
          "own first"));
    }
  }
  EnhanceParams p;
  if (e.has_gain()) p.gain = e.gain();
  if (!(p.gain > 1.0 && p.gain <= MaxEnhanceGain())) {
    return absl::InvalidArgumentError(absl::StrCat("enhance.gain must be in (1, ", MaxEnhanceGain(),
                                                   "] (a gain <= 1 smooths: ask for a smoothing job), got ", p.gain));
  }
  for (const auto& [field, value] :
       {std::pair{"enhance.detail_scale", e.detail_scale()}, std::pair{"enhance.detail_scale_h", e.detail_scale_h()}}) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
      return absl::InvalidArgumentError(absl::StrCat(field, " must be finite and >= 0 (0 = the default), got ", value));
    }
  }
  if (e.detail_scale() > 0.0 && e.detail_scale_h() > 0.0) {
    return absl::InvalidArgumentError("enhance.detail_scale and enhance.detail_scale_h are both set; give one");
  }
  p.detail_scale = e.detail_scale();
  if (e.detail_scale_h() > 0.0) p.detail_scale_h = e.detail_scale_h();
  p.smooth_first = e.smooth_first();
  p.method =
      e.method() == v1::ENHANCE_METHOD_INVERTED_FLOW ? EnhanceMethod::kInvertedFlow : EnhanceMethod::kScreenedPoisson;
  j.enhance = std::move(p);
  return absl::OkStatus();
}

}  // namespace

// Visible ASCII without spaces, so that the log line's "job=ID" stays one field.
absl::Status CheckJobId(const std::string& id) {
  if (id.size() > kMaxJobIdLength) {
    return absl::InvalidArgumentError(
        absl::StrCat("job_id: ", id.size(), " characters, above the limit of ", kMaxJobIdLength));
  }
  for (size_t i = 0; i < id.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(id[i]);
    if (c < 0x21 || c > 0x7e) {
      return absl::InvalidArgumentError(absl::StrCat("job_id: character ", i, " is byte ", static_cast<int>(c),
                                                     "; a job id is printable ASCII without spaces (0x21-0x7E)"));
    }
  }
  return absl::OkStatus();
}

grpc::Status ToGrpc(const absl::Status& s) {
  std::string message(s.message());
  if (message.size() > 2000) message = message.substr(0, 2000) + "...";
  return grpc::Status(static_cast<grpc::StatusCode>(s.code()), message);
}

absl::StatusOr<JobParams> FromProto(const v1::JobSpec& spec, int max_iterations) {
  for (const absl::Status& s : {CheckEnum("weights", spec.weights(), v1::UmbrellaWeights_descriptor()),
                                CheckEnum("boundary", spec.boundary(), v1::BoundaryMode_descriptor()),
                                CheckEnum("adaptive.mode", spec.adaptive().mode(), v1::AdaptiveMode_descriptor()),
                                CheckEnum("integration", spec.integration(), v1::Integration_descriptor())}) {
    if (!s.ok()) return s;
  }
  if (absl::Status s = CheckJobId(spec.job_id()); !s.ok()) return s;
  JobParams j;
  j.job_id = spec.job_id();
  j.strength_attribute = spec.strength_attribute();
  FlowParams& p = j.flow;
  if (!spec.flow().empty()) {  // empty: the default job's rule (FlowParams::flow)
    absl::StatusOr<FlowId> flow = ParseFlowName(spec.flow());
    if (!flow.ok()) return flow.status();
    p.flow = *flow;
  }
  if (spec.iterations() > static_cast<uint32_t>(max_iterations)) {
    return absl::InvalidArgumentError(
        absl::StrCat("iterations ", spec.iterations(), " is above this server's limit of ", max_iterations));
  }
  p.iterations = static_cast<int>(spec.iterations());  // 0: automatic stopping
  p.max_auto_iterations = std::min(max_iterations, kMaxAutoIterations);
  if (spec.step() != 0.0) p.step = spec.step();
  p.weights = spec.weights() == v1::UMBRELLA_WEIGHTS_INVERSE_DISTANCE ? UmbrellaWeights::kInverseDistance
                                                                      : UmbrellaWeights::kUniform;
  if (spec.has_taubin_mu()) p.taubin_mu = spec.taubin_mu();
  if (spec.has_taubin_pass_band()) p.taubin_pass_band = spec.taubin_pass_band();
  if (spec.has_tangential_weight()) p.tangential_weight = spec.tangential_weight();
  if (spec.has_epsilon()) p.epsilon = spec.epsilon();
  const v1::NormalFilter& nf = spec.normal_filter();
  // Counts above 100 are refused by validation; the clamp only keeps them from wrapping.
  if (nf.has_normal_iterations()) {
    p.normal_filter.normal_iterations = static_cast<int>(std::min(nf.normal_iterations(), 1000u));
  }
  if (nf.has_vertex_iterations()) {
    p.normal_filter.vertex_iterations = static_cast<int>(std::min(nf.vertex_iterations(), 1000u));
  }
  if (nf.has_sigma_spatial()) p.normal_filter.sigma_spatial = nf.sigma_spatial();
  if (nf.has_sigma_range()) p.normal_filter.sigma_range = nf.sigma_range();
  switch (spec.adaptive().mode()) {
    case v1::ADAPTIVE_MODE_CONSTANT:
      p.adaptive = AdaptiveMode::kConstant;
      break;
    case v1::ADAPTIVE_MODE_RING1:
      p.adaptive = AdaptiveMode::kRing1;
      break;
    case v1::ADAPTIVE_MODE_RING2:
      p.adaptive = AdaptiveMode::kRing2;
      break;
    default:
      p.adaptive = AdaptiveMode::kNone;
      break;
  }
  p.adaptive_threshold = spec.adaptive().threshold();
  if (spec.adaptive().recompute_every() > 0) {
    p.adaptive_recompute_every = static_cast<int>(std::min<uint32_t>(spec.adaptive().recompute_every(), 1u << 30));
  }
  p.boundary = spec.boundary() == v1::BOUNDARY_MODE_CURVE   ? BoundaryMode::kCurve
               : spec.boundary() == v1::BOUNDARY_MODE_FIXED ? BoundaryMode::kFixed
                                                            : BoundaryMode::kAuto;
  p.tolerance = spec.tolerance();
  p.max_displacement = spec.max_displacement();
  p.max_displacement_h = spec.max_displacement_h();
  if (spec.integration() == v1::INTEGRATION_IMPLICIT) {
    p.integration = Integration::kImplicit;
    if (spec.has_theta()) p.theta = spec.theta();
  } else if (spec.has_theta()) {
    return absl::InvalidArgumentError("theta is for integration IMPLICIT only");
  }
  if (absl::Status s = ValidateFlowParams(p, 0); !s.ok()) return s;

  if (spec.output().quantization_bits() > static_cast<uint32_t>(kMaxQuantizationBits)) {
    return absl::InvalidArgumentError(absl::StrCat("output.quantization_bits must be 0 (lossless) or 1..",
                                                   kMaxQuantizationBits, ", got ", spec.output().quantization_bits()));
  }
  j.output.quantization_bits = static_cast<int>(spec.output().quantization_bits());
  j.output.method = spec.output().edgebreaker() ? DracoMethod::kEdgebreaker : DracoMethod::kSequential;
  j.detect_features = spec.features().enabled();
  const double threshold = spec.features().min_abs_curvature();
  if (!std::isfinite(threshold) || threshold < 0.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("features.min_abs_curvature must be finite and >= 0, got ", threshold));
  }
  j.features.min_abs_curvature = threshold;
  if (spec.has_enhance()) {
    if (absl::Status s = EnhanceFromProto(spec, j); !s.ok()) return s;
  }
  return j;
}

void ToProto(const ValidationReport& r, v1::ValidationReport* out) {
  out->set_vertices(r.vertices);
  out->set_faces(r.faces);
  out->set_faces_out_of_range(r.faces_out_of_range);
  out->set_faces_repeated_index(r.faces_repeated_index);
  out->set_zero_area_faces(r.zero_area_faces);
  out->set_duplicate_faces(r.duplicate_faces);
  out->set_unreferenced_vertices(r.unreferenced_vertices);
  out->set_non_finite_vertices(r.non_finite_vertices);
  out->set_edges(r.edges);
  out->set_boundary_edges(r.boundary_edges);
  out->set_boundary_loops(r.boundary_loops);
  out->set_nonmanifold_edges(r.nonmanifold_edges);
  out->set_nonmanifold_vertices(r.nonmanifold_vertices);
  out->set_inconsistently_oriented_edges(r.inconsistently_oriented_edges);
  out->set_connected_components(r.connected_components);
  out->set_closed(r.closed());
  out->set_manifold(r.manifold());
}

void ToProto(const MeshMetrics& m, v1::MeshMetrics* out) {
  out->set_area(m.area);
  out->set_signed_volume(m.signed_volume);
  out->set_edge_length_mean(m.edge_length_mean);
  out->set_edge_length_cv(m.edge_length_cv);
  out->set_min_angle_deg(m.min_angle_deg);
  out->set_mean_min_angle_deg(m.mean_angle_deg);
  out->set_share_angles_below_10deg(m.share_angles_below_10deg);
}

v1::ProgressPhase ToProto(Phase phase) {
  switch (phase) {
    case Phase::kSmoothing:
      return v1::PROGRESS_PHASE_SMOOTHING;
    case Phase::kNoiseEstimate:
      return v1::PROGRESS_PHASE_NOISE_ESTIMATE;
    case Phase::kChoosing:
      return v1::PROGRESS_PHASE_CHOOSING;
    case Phase::kWriting:
      return v1::PROGRESS_PHASE_WRITING;
    case Phase::kEnhancing:
      return v1::PROGRESS_PHASE_ENHANCING;
  }
  return v1::PROGRESS_PHASE_UNSPECIFIED;
}

void ToProto(const Progress& p, v1::Progress* out) {
  out->set_phase(ToProto(p.phase));
  out->set_flow(std::string(FlowName(p.flow)));
  out->set_iteration(static_cast<uint32_t>(p.iteration));
  out->set_total(static_cast<uint32_t>(p.total));
  out->set_max_displacement(p.max_displacement);
  out->set_mean_displacement(p.mean_displacement);
  out->set_moved_share(p.moved_share);
}

void ToProto(const ParameterInfo& p, v1::ParameterInfo* out) {
  out->set_name(p.name);
  out->set_description(p.description);
  out->set_default_value(p.default_value);
  out->set_min_value(p.min_value);
  out->set_max_value(p.max_value);
  out->set_min_exclusive(p.min_exclusive);
  out->set_max_exclusive(p.max_exclusive);
  for (const std::string& c : p.choices) out->add_choices(c);
}

void ToProto(const JobParams& params, const FlowResult& result, v1::EffectiveParameters* out) {
  const FlowParams& p = params.flow;
  out->set_flow(std::string(FlowName(result.flow)));
  out->set_iterations_requested(static_cast<uint32_t>(p.iterations));
  out->set_iterations_run(static_cast<uint32_t>(result.iterations_run));
  out->set_step(p.step.value_or(DefaultStep(result.flow)));
  out->set_effective_step(result.effective_step);
  out->set_taubin_mu(result.effective_mu);
  out->set_mean_edge_length(result.mean_edge_length);
  out->set_stop_reason(std::string(StopReasonName(result.stop_reason)));
  if (result.auto_stop) {
    out->set_noise_estimate(result.auto_stop->noise_sigma_h);
    out->set_noise_removed(result.auto_stop->displacement_h);
    out->set_noise_estimate_detail_free(result.auto_stop->detail_free_h);
  }
  out->set_outliers_moved(result.outliers_moved);
  out->set_max_displacement(result.displacement_bound);
  if (p.integration == Integration::kImplicit) {
    out->set_integration(v1::INTEGRATION_IMPLICIT);
    out->set_theta(p.theta);
  }
  out->set_weights(p.weights == UmbrellaWeights::kInverseDistance ? v1::UMBRELLA_WEIGHTS_INVERSE_DISTANCE
                                                                  : v1::UMBRELLA_WEIGHTS_UNIFORM);
  out->set_boundary(result.boundary == BoundaryMode::kCurve ? v1::BOUNDARY_MODE_CURVE : v1::BOUNDARY_MODE_FIXED);
  v1::AdaptiveThreshold* a = out->mutable_adaptive();
  a->set_mode(p.adaptive == AdaptiveMode::kConstant ? v1::ADAPTIVE_MODE_CONSTANT
              : p.adaptive == AdaptiveMode::kRing1  ? v1::ADAPTIVE_MODE_RING1
              : p.adaptive == AdaptiveMode::kRing2  ? v1::ADAPTIVE_MODE_RING2
                                                    : v1::ADAPTIVE_MODE_NONE);
  a->set_threshold(p.adaptive_threshold);
  a->set_recompute_every(static_cast<uint32_t>(p.adaptive_recompute_every));
  out->set_epsilon(p.epsilon);
  out->set_tangential_weight(p.tangential_weight);
  v1::NormalFilter* nf = out->mutable_normal_filter();
  nf->set_normal_iterations(static_cast<uint32_t>(p.normal_filter.normal_iterations));
  nf->set_vertex_iterations(static_cast<uint32_t>(p.normal_filter.vertex_iterations));
  nf->set_sigma_spatial(p.normal_filter.sigma_spatial);
  nf->set_sigma_range(p.normal_filter.sigma_range);
  out->mutable_output()->set_quantization_bits(static_cast<uint32_t>(params.output.quantization_bits));
  out->mutable_output()->set_edgebreaker(params.output.method == DracoMethod::kEdgebreaker);
}

v1::Summary MakeSummary(const JobReport& report, const JobParams& params) {
  v1::Summary summary;
  summary.set_job_id(report.job_id);
  ToProto(report.before, summary.mutable_before());
  ToProto(report.after, summary.mutable_after());
  if (report.displacement.has_value()) {
    summary.set_rms_displacement(report.displacement->rms);
    summary.set_max_displacement(report.displacement->max);
    summary.set_flipped_normals(report.displacement->flipped_normals);
    summary.set_vertices_at_bound(report.displacement->at_bound);
  }
  v1::Timings* t = summary.mutable_timings();
  t->set_decode_seconds(report.decode_seconds);
  t->set_queue_seconds(report.queue_seconds);
  t->set_smooth_seconds(report.smooth_seconds);
  t->set_encode_seconds(report.encode_seconds);
  t->set_total_seconds(report.total_seconds);
  ToProto(params, report.flow, summary.mutable_parameters());
  if (report.enhanced.has_value() && params.enhance.has_value()) {
    v1::EffectiveParameters* p = summary.mutable_parameters();
    if (!report.enhanced->smoothing.has_value()) {  // no smoothing ran: no flow to report
      p->clear_flow();
      p->clear_step();
      p->clear_effective_step();
      p->clear_taubin_mu();
      p->clear_stop_reason();
    }
    v1::Enhancement* e = p->mutable_enhance();
    e->set_gain(params.enhance->gain);
    e->set_detail_scale(report.enhanced->detail_scale);
    e->set_detail_scale_h(report.enhanced->detail_scale / report.enhanced->mean_edge_length);
    e->set_smooth_first(params.enhance->smooth_first);
    e->set_method(params.enhance->method == EnhanceMethod::kInvertedFlow ? v1::ENHANCE_METHOD_INVERTED_FLOW
                                                                         : v1::ENHANCE_METHOD_SCREENED_POISSON);
    p->set_enhance_held_back(report.enhanced->held_back);
  }
  summary.set_result_bytes(report.result_bytes);
  for (const std::string& w : report.warnings) summary.add_warnings(w);
  if (report.features.has_value()) {
    v1::FeatureCounts* f = summary.mutable_features();
    f->set_ridge_vertices(report.features->ridges);
    f->set_ravine_vertices(report.features->ravines);
    f->set_classified_vertices(report.features->classified);
    f->set_detect_seconds(report.features->detect_seconds);
  }
  return summary;
}

std::string_view JobFlowName(const JobReport& report, const JobParams& params) {
  if (params.enhance.has_value()) return "enhance";
  return FlowName(report.flow.iterations_run > 0 ? report.flow.flow : params.flow.flow.value_or(kDefaultFlow));
}

std::string JobLogLine(const JobReport& report, const JobParams& params, std::string_view peer) {
  // printf's own rounding of the times, as the log has always had it.
  char seconds[128];
  std::snprintf(seconds, sizeof seconds, "decode=%.3fs queue=%.3fs smooth=%.3fs encode=%.3fs", report.decode_seconds,
                report.queue_seconds, report.smooth_seconds, report.encode_seconds);
  return absl::StrCat(
      "meshsmoothd job=", report.job_id, " flow=", std::string(JobFlowName(report, params)),
      " vertices=", report.vertices, " iterations=", report.flow.iterations_run, "/",
      params.flow.iterations == kAutoIterations ? std::string("auto") : absl::StrCat(params.flow.iterations),
      " status=", report.status, " ", seconds, peer.empty() ? "" : absl::StrCat(" peer=", io::Sv(peer)),
      report.error.empty() ? "" : absl::StrCat(" error=", JsonQuote(report.error)));
}

std::string JobStateName(v1::JobState state) {
  std::string name = v1::JobState_Name(state);
  return name.rfind("JOB_STATE_", 0) == 0 ? name.substr(10) : name;
}

}  // namespace meshsmooth::server
