#include "client/job_options.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/flows/catalogue.h"
#include "server/convert.h"

namespace meshsmooth::client {
namespace {

const std::map<std::string, v1::AdaptiveMode>& AdaptiveModes() {
  static const auto* modes = new std::map<std::string, v1::AdaptiveMode>{{"none", v1::ADAPTIVE_MODE_NONE},
                                                                         {"constant", v1::ADAPTIVE_MODE_CONSTANT},
                                                                         {"ring1", v1::ADAPTIVE_MODE_RING1},
                                                                         {"ring2", v1::ADAPTIVE_MODE_RING2}};
  return *modes;
}

// InvalidArgument naming `parameter` unless `value` is one of `choices`.
absl::Status CheckChoice(const char* parameter, const std::string& value, const std::vector<std::string>& choices) {
  if (std::find(choices.begin(), choices.end(), value) != choices.end()) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(parameter, " must be one of ", absl::StrJoin(choices, ", "), "; got '", value, "'"));
}

absl::Status CheckChoices(const SmoothOptions& o) {
  std::vector<std::string> flows = FlowNames();
  flows.insert(flows.begin(), "auto");
  if (!o.flow.empty()) {
    if (absl::Status s = CheckChoice("flow", o.flow, flows); !s.ok()) return s;
  }
  if (absl::Status s = CheckChoice("weights", o.weights, {"u0", "u1"}); !s.ok()) return s;
  if (absl::Status s = CheckChoice("method", o.method, {"poisson", "inverted-flow"}); !s.ok()) return s;
  if (absl::Status s = CheckChoice("adaptive", o.adaptive, {"none", "constant", "ring1", "ring2"}); !s.ok()) return s;
  return CheckChoice("boundary", o.boundary, {"auto", "fixed", "curve"});
}

}  // namespace

v1::JobSpec SpecFrom(const SmoothOptions& o, bool strength_values) {
  v1::JobSpec spec;
  spec.set_job_id(o.job_id);
  if (o.flow != "auto") spec.set_flow(o.flow);  // none named: the server chooses
  spec.set_iterations(o.iterations);
  spec.set_step(o.step);
  spec.set_weights(o.weights == "u1" ? v1::UMBRELLA_WEIGHTS_INVERSE_DISTANCE : v1::UMBRELLA_WEIGHTS_UNIFORM);
  if (o.mu > 0) spec.set_taubin_mu(o.mu);
  if (o.pass_band > 0) spec.set_taubin_pass_band(o.pass_band);
  if (o.tangential_weight >= 0) spec.set_tangential_weight(o.tangential_weight);
  if (o.epsilon > 0) spec.set_epsilon(o.epsilon);
  v1::NormalFilter* nf = spec.mutable_normal_filter();
  if (o.normal_iterations > 0) nf->set_normal_iterations(o.normal_iterations);
  if (o.vertex_iterations > 0) nf->set_vertex_iterations(o.vertex_iterations);
  if (o.sigma_spatial > 0) nf->set_sigma_spatial(o.sigma_spatial);
  if (o.sigma_range > 0) nf->set_sigma_range(o.sigma_range);
  const auto mode = AdaptiveModes().find(o.adaptive);  // checked before (CheckChoices)
  spec.mutable_adaptive()->set_mode(mode != AdaptiveModes().end() ? mode->second : v1::ADAPTIVE_MODE_NONE);
  spec.mutable_adaptive()->set_threshold(o.threshold);
  spec.mutable_adaptive()->set_recompute_every(o.recompute_every);
  spec.set_boundary(o.boundary == "curve"   ? v1::BOUNDARY_MODE_CURVE
                    : o.boundary == "fixed" ? v1::BOUNDARY_MODE_FIXED
                                            : v1::BOUNDARY_MODE_UNSPECIFIED);
  spec.set_tolerance(o.tolerance);
  spec.mutable_output()->set_quantization_bits(o.quantization_bits);
  spec.mutable_output()->set_edgebreaker(o.edgebreaker);
  if (o.implicit) spec.set_integration(v1::INTEGRATION_IMPLICIT);
  if (o.theta != 0.0) spec.set_theta(o.theta);  // without --implicit: refused, naming theta
  if (o.ridges) {
    spec.mutable_features()->set_enabled(true);
    spec.mutable_features()->set_min_abs_curvature(o.ridge_threshold);
  }
  if (o.strength.any() || strength_values) spec.set_strength_attribute(kStrengthAttribute);
  if (o.enhance) {
    v1::Enhancement* e = spec.mutable_enhance();
    if (o.gain != 0.0) e->set_gain(o.gain);
    e->set_smooth_first(o.smooth_first);
    if (o.method == "inverted-flow") e->set_method(v1::ENHANCE_METHOD_INVERTED_FLOW);
    // Checked before (CheckSmoothOptions).
    if (absl::StatusOr<DisplacementBoundOption> d = ParseLengthOption("--detail", o.detail); d.ok()) {
      if (d->in_h) {
        e->set_detail_scale_h(d->value);
      } else {
        e->set_detail_scale(d->value);
      }
    }
  }
  // Checked before (CheckSmoothOptions).
  if (absl::StatusOr<DisplacementBoundOption> bound = ParseMaxDisplacement(o.max_displacement); bound.ok()) {
    if (bound->in_h) {
      spec.set_max_displacement_h(bound->value);
    } else {
      spec.set_max_displacement(bound->value);
    }
  }
  return spec;
}

absl::StatusOr<DisplacementBoundOption> ParseLengthOption(const char* flag, const std::string& text) {
  DisplacementBoundOption bound;
  if (text.empty()) return bound;
  std::string number = text;
  if (number.back() == 'h') {
    bound.in_h = true;
    number.pop_back();
  }
  if (!absl::SimpleAtod(number, &bound.value) || !std::isfinite(bound.value) || bound.value < 0.0) {
    return absl::InvalidArgumentError(
        absl::StrCat(flag, ": '", text,
                     "' is not a length; give a finite number >= 0 in mesh units (0.02) or in mean edge "
                     "lengths (0.5h)"));
  }
  return bound;
}

absl::StatusOr<DisplacementBoundOption> ParseMaxDisplacement(const std::string& text) {
  return ParseLengthOption("--max-displacement", text);
}

absl::Status CheckSmoothOptions(const SmoothOptions& options) {
  if (absl::Status s = CheckChoices(options); !s.ok()) return s;
  if (absl::Status s = CheckStrengthOptions(options.strength); !s.ok()) return s;
  if (absl::Status s = ParseMaxDisplacement(options.max_displacement).status(); !s.ok()) return s;
  if (absl::Status s = ParseLengthOption("--detail", options.detail).status(); !s.ok()) return s;
  v1::JobSpec spec = SpecFrom(options);
  spec.clear_job_id();
  return server::FromProto(spec, std::numeric_limits<int>::max()).status();
}

}  // namespace meshsmooth::client
