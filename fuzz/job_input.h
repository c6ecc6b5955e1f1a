// The whole-job fuzz target's input format: kSpecBytes bytes that choose a JobSpec, then the
// Draco upload. Shared by the target (job_fuzzer.cc) and the seed writer (seeds.cc).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/flows/catalogue.h"
#include "meshsmooth/v1/smoothing.pb.h"

namespace meshsmooth::fuzz {

inline constexpr size_t kSpecBytes = 14;

// Byte k of the head (0 where the input is shorter):
//   0 flow: k = b % (n + 2) with n flows: FlowNames()[k] for k < n, "" (the default) for n,
//     an unknown name for n + 1
//   1 iterations 1 + b % 3
//   2, 3 step (little endian u16 s): 0 = unset; 0xffff = -1; else
//     (1 + s % 1024) / 1024 * 2^((s >> 10) % 32 - 20), in (0, 2048]
//   4 weights, 5 boundary, 6 adaptive mode: the enum value b % 4, or 99 when b % 4 == 3 and
//     b >= 128 (an unknown value)
//   7 adaptive threshold b / 16, recompute_every b % 16
//   8 bit k set: taubin_mu (b / 255 * 1.2), pass band, tangential weight (b / 32), epsilon
//     (b / 255) are set from byte 9 (k = 0..3); bit 4: tolerance 1e-3
//   9 the value for byte 8's fields
//   10 features: bit 0 enabled; min_abs_curvature (b >> 1) / 8
//   11 output: quantization bits b % 32 (above 24 is out of range), Edgebreaker when b >= 128
//   12 bit k set: normal_filter's normal_iterations (b13 % 4), vertex_iterations
//     (1 + b13 / 4 % 8), sigma_spatial ((1 + b13) / 25.6), sigma_range ((1 + b13) / 128) are
//     set from byte 13 (k = 0..3)
inline v1::JobSpec SpecFromBytes(std::string_view head) {
  uint8_t b[kSpecBytes] = {};
  for (size_t i = 0; i < kSpecBytes && i < head.size(); ++i) b[i] = static_cast<uint8_t>(head[i]);
  auto enum_value = [](uint8_t v) { return v % 4 == 3 && v >= 128 ? 99 : v % 4; };
  v1::JobSpec spec;
  const size_t flows = FlowNames().size();
  const size_t flow = b[0] % (flows + 2);
  spec.set_flow(flow < flows ? FlowNames()[flow] : flow == flows ? "" : "no_such_flow");
  spec.set_iterations(1 + b[1] % 3);
  const uint16_t s = static_cast<uint16_t>(b[2] | b[3] << 8);
  if (s == 0xffff) {
    spec.set_step(-1.0);
  } else if (s != 0) {
    spec.set_step(std::ldexp((1 + s % 1024) / 1024.0, (s >> 10) % 32 - 20));
  }
  spec.set_weights(static_cast<v1::UmbrellaWeights>(enum_value(b[4])));
  spec.set_boundary(static_cast<v1::BoundaryMode>(enum_value(b[5])));
  spec.mutable_adaptive()->set_mode(static_cast<v1::AdaptiveMode>(enum_value(b[6])));
  spec.mutable_adaptive()->set_threshold(b[7] / 16);
  spec.mutable_adaptive()->set_recompute_every(b[7] % 16);
  if (b[8] & 1) spec.set_taubin_mu(b[9] / 255.0 * 1.2);
  if (b[8] & 2) spec.set_taubin_pass_band(b[9] / 255.0);
  if (b[8] & 4) spec.set_tangential_weight(b[9] / 32.0);
  if (b[8] & 8) spec.set_epsilon(b[9] / 255.0);
  if (b[8] & 16) spec.set_tolerance(1e-3);
  spec.mutable_features()->set_enabled(b[10] & 1);
  spec.mutable_features()->set_min_abs_curvature((b[10] >> 1) / 8.0);
  spec.mutable_output()->set_quantization_bits(b[11] % 32);
  spec.mutable_output()->set_edgebreaker(b[11] >= 128);
  v1::NormalFilter* filter = spec.mutable_normal_filter();
  if (b[12] & 1) filter->set_normal_iterations(b[13] % 4);
  if (b[12] & 2) filter->set_vertex_iterations(1 + b[13] / 4 % 8);
  if (b[12] & 4) filter->set_sigma_spatial((1 + b[13]) / 25.6);
  if (b[12] & 8) filter->set_sigma_range((1 + b[13]) / 128.0);
  return spec;
}

}  // namespace meshsmooth::fuzz
