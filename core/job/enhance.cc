#include "core/job/enhance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/flows/catalogue.h"
#include "core/flows/driver.h"
#include "core/flows/flow_kernel.h"
#include "core/flows/implicit.h"
#include "core/job/repair.h"
#include "core/measure/metrics.h"

namespace meshsmooth {

double MaxEnhanceGain() { return 100.0; }

std::vector<ParameterInfo> EnhanceParameters() {
  const EnhanceParams d;
  return {
      {"enhance.gain",
       "the factor detail shorter than the detail scale grows by; longer waves stay",
       d.gain,
       1.0,
       MaxEnhanceGain(),
       true,
       false,
       {}},
      {"enhance.detail_scale",
       "the detail scale d in mesh units: a wave of wavelength d grows by (1 + gain) / 2; 0 = detail_scale_h",
       0.0,
       0.0,
       std::numeric_limits<double>::infinity(),
       false,
       true,
       {}},
      {"enhance.detail_scale_h",
       absl::StrFormat("d in mean edge lengths of the input; 0 with detail_scale 0 = %g", d.detail_scale_h),
       0.0,
       0.0,
       std::numeric_limits<double>::infinity(),
       false,
       true,
       {}},
      {"enhance.smooth_first",
       "a noisy input (one the default job would smooth): 0 = refused (FAILED_PRECONDITION), 1 = smoothed by the "
       "default job first",
       0.0,
       0.0,
       1.0,
       false,
       false,
       {}},
      {"enhance.method",
       "how: one screened-Poisson solve (stable for any gain)",
       0,
       0,
       0,
       false,
       false,
       {"ENHANCE_METHOD_SCREENED_POISSON"}},
  };
}

namespace {

absl::Status ValidateEnhanceParams(const Mesh& mesh, const EnhanceParams& p) {
  if (!(p.gain >= 0.0 && p.gain <= MaxEnhanceGain())) {
    return absl::InvalidArgumentError(
        absl::StrFormat("the gain must be in [0, %g] (> 1 sharpens, 1 leaves the mesh, < 1 smooths), got %g",
                        MaxEnhanceGain(), p.gain));
  }
  if (!(p.detail_scale >= 0.0) || !std::isfinite(p.detail_scale) || !(p.detail_scale_h > 0.0) ||
      !std::isfinite(p.detail_scale_h)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("the detail scale must be finite and >= 0 (mesh units; 0 = %g mean edge lengths), got %g",
                        p.detail_scale_h, p.detail_scale));
  }
  if (!(p.turn_halvings >= 0)) {
    return absl::InvalidArgumentError(absl::StrFormat("turn_halvings must be >= 0, got %d", p.turn_halvings));
  }
  if (!(p.inverted_iterations >= 1) || !(p.inverted_step > 0.0 && p.inverted_step < 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("the inverted flow needs at least one step and a step in (0, 1), got %d and %g",
                        p.inverted_iterations, p.inverted_step));
  }
  const int32_t n = mesh.num_vertices();
  if (!p.locked.empty() && p.locked.size() != static_cast<size_t>(n)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the lock mask has ", p.locked.size(), " entries for ", n, " vertices"));
  }
  if (absl::Status s = ValidateStrength(p.strength, n); !s.ok()) return s;
  for (const Vec3& q : mesh.positions) {
    if (!IsFinite(q)) return absl::InvalidArgumentError("the mesh has vertices with NaN or infinite coordinates");
  }
  return absl::OkStatus();
}

// The default job on a copy of `mesh`: its result when it smoothed (the input is noisy), else
// nothing.
absl::StatusOr<std::optional<std::pair<Mesh, FlowResult>>> SmoothIfNoisy(const Mesh& mesh, Topology& topo,
                                                                         const EnhanceParams& p,
                                                                         const RunControl& control) {
  FlowParams job;
  job.locked = p.locked;
  job.strength = p.strength;
  job.threads = p.threads;
  Mesh copy = mesh;
  absl::StatusOr<FlowResult> r = Smooth(copy, topo, job, control);
  if (!r.ok()) return r.status();
  if (r->iterations_run == 0) return std::nullopt;  // no noise, no estimate, or no gain from smoothing
  return std::make_optional(std::pair{std::move(copy), *std::move(r)});
}

// U0 of eq. (3) at every vertex of `pos`: the mean of the ring less the vertex.
void Umbrellas(const Topology& topo, const Vec3* pos, Vec3* out) {
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    const int32_t begin = topo.ring_offsets[v], end = topo.ring_offsets[v + 1];
    if (begin == end) {
      out[v] = {};
      continue;
    }
    Vec3 sum{};
    for (int32_t k = begin; k < end; ++k) sum = sum + pos[topo.ring[k]];
    out[v] = sum * (1.0 / (end - begin)) - pos[v];
  }
}

// EnhanceMethod::kInvertedFlow from `input` (F) and `base` (B, F smoothed at the detail scale)
// into `pos` (F on entry). Returns the steps run.
absl::StatusOr<int> InvertedFlow(const Topology& topo, const uint8_t* role, const EnhanceParams& p, const Vec3* input,
                                 const Vec3* base, double h, const RunControl& control, Vec3* pos) {
  const int32_t n = topo.num_vertices();
  std::vector<Vec3> target(n), bound(n), u(n);
  std::vector<double> limit(n);
  Umbrellas(topo, input, target.data());
  Umbrellas(topo, base, bound.data());
  for (int32_t v = 0; v < n; ++v) {
    const Vec3 band = target[v] - bound[v];
    target[v] = bound[v] + band * p.gain;              // U*
    limit[v] = p.inverted_step * p.gain * Norm(band);  // eq. (14)'s bound: lambda T(P)
  }
  std::vector<Vec3> next(pos, pos + n);
  const double converged = 1e-6 * h;
  int step = 0;
  while (step < p.inverted_iterations) {
    if (absl::Status s = control.stop.Check(); !s.ok()) return s;
    Umbrellas(topo, pos, u.data());
    double largest = 0.0;
    for (int32_t v = 0; v < n; ++v) {
      if (role[v] != flows::kFree) continue;
      Vec3 move = (u[v] - target[v]) * p.inverted_step;
      const double length = Norm(move);
      if (length > limit[v]) move = move * (limit[v] / length);
      if (!p.strength.empty()) move = move * static_cast<double>(p.strength[v]);
      next[v] = pos[v] + move;
      largest = std::max(largest, Norm(move));
    }
    std::copy(next.begin(), next.end(), pos);
    ++step;
    if (largest < converged) break;
  }
  return step;
}

// Holds the enhancement back where it turns a face over (Enhance's comment in enhance.h): writes
// F + t_v (E - F) into `enhanced` (E on entry) and the vertices held back and the share kept into
// `result`. `input` is the mesh's positions before any smoothing, `start` (F) those enhanced.
void HoldBackTurnedFaces(const Mesh& mesh, const Topology& topo, const Vec3* input, const Vec3* start, int halvings,
                         std::vector<Vec3>& enhanced, EnhanceResult& result) {
  const int32_t n = topo.num_vertices();
  const std::vector<Vec3> full = enhanced;  // E
  // A face the smoothing turned stays turned at t = 0: not the enhancement's to undo.
  std::vector<uint8_t> turned_at_start(topo.faces.size(), 0);
  if (input != start) {
    for (size_t i = 0; i < topo.faces.size(); ++i) {
      turned_at_start[i] = NormalFlipped(mesh.triangles[topo.faces[i]], input, start);
    }
  }
  std::vector<double> share(n, 1.0);  // t
  std::vector<uint8_t> lower(n);
  for (int round = 0;; ++round) {
    std::fill(lower.begin(), lower.end(), 0);
    bool any = false;
    for (size_t i = 0; i < topo.faces.size(); ++i) {
      const Triangle& t = mesh.triangles[topo.faces[i]];
      if (turned_at_start[i] || !NormalFlipped(t, input, enhanced.data())) continue;
      for (int32_t v : t) lower[v] = 1;
      any = true;
    }
    if (!any) break;
    // Each round past `halvings` sets a share > 0 to 0 (a face with every share 0 is F's, not
    // turned): the rounds end.
    for (int32_t v = 0; v < n; ++v) {
      if (!lower[v]) continue;
      share[v] = round < halvings ? 0.5 * share[v] : 0.0;
      enhanced[v] = start[v] + (full[v] - start[v]) * share[v];
    }
  }
  double moved = 0.0, kept = 0.0;
  for (int32_t v = 0; v < n; ++v) {
    const double m = Norm(full[v] - start[v]);
    moved += m * m;
    kept += share[v] * share[v] * m * m;
    result.held_back += share[v] < 1.0 && m > 0.0;
  }
  result.kept = moved > 0.0 ? std::sqrt(kept / moved) : 1.0;
}

}  // namespace

absl::StatusOr<EnhanceResult> Enhance(Mesh& mesh, Topology& topo, const EnhanceParams& p, const RunControl& control) {
  if (absl::Status s = ValidateEnhanceParams(mesh, p); !s.ok()) return s;
  if (topo.num_vertices() != mesh.num_vertices()) {
    return absl::InvalidArgumentError("the topology was built for another mesh");
  }
  EnhanceResult result;
  const double h = MeanEdgeLength(mesh, topo);
  if (!(h > 0.0) || !std::isfinite(h)) {
    return absl::InvalidArgumentError("the mesh has no edge of non-zero length to enhance");
  }
  result.mean_edge_length = h;
  result.detail_scale = p.detail_scale > 0.0 ? p.detail_scale : p.detail_scale_h * h;

  std::vector<Vec3> input;  // the positions given, when smoothing moved them first
  absl::StatusOr<std::optional<std::pair<Mesh, FlowResult>>> smoothed = SmoothIfNoisy(mesh, topo, p, control);
  if (!smoothed.ok()) return smoothed.status();
  if (smoothed->has_value()) {
    const FlowResult& run = (*smoothed)->second;
    if (!p.smooth_first) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "the input is noisy (estimated noise %.3g mean edge lengths: the default job would smooth it with %d "
          "iterations of %s); enhancing would amplify the noise most. Smooth it first (meshsmooth smooth, or "
          "--smooth-first)",
          run.auto_stop ? run.auto_stop->noise_sigma_h : 0.0, run.iterations_run, FlowName(run.flow)));
    }
    input = std::exchange(mesh.positions, std::move((*smoothed)->first.positions));
    result.smoothing = run;
  }

  const int32_t n = mesh.num_vertices();
  std::vector<uint8_t> role(n, flows::kFixed);
  bool closed = true;
  for (int32_t v = 0; v < n; ++v) {
    closed &= topo.kind[v] == VertexKind::kInterior || topo.kind[v] == VertexKind::kIsolated;
    if (topo.kind[v] != VertexKind::kInterior) continue;
    if (!p.locked.empty() && p.locked[v] != 0) continue;
    if (!p.strength.empty() && p.strength[v] == 0.0f) continue;
    role[v] = flows::kFree;
  }
  FlowParams system;
  system.flow = FlowId::kMcf;
  system.strength = p.strength;
  system.implicit_solver = p.solver;
  system.cg_tolerance = 1e-10;
  const double alpha = 2.0 * std::numbers::pi * std::numbers::pi / (result.detail_scale * result.detail_scale);
  FlowParams thread_params;
  thread_params.threads = p.threads;
  const int threads = flows::ThreadsFor(n, thread_params);
  const double volume = closed ? job::EnclosedVolume(mesh.positions.data(), topo, threads) : 0.0;
  // Screened Poisson solves for the result; the inverted flow solves for its base B, the same
  // system with gain 0 (the input smoothed at the detail scale), and steps towards the result.
  const bool poisson = p.method == EnhanceMethod::kScreenedPoisson;
  flows::ImplicitStepper stepper(topo, system, role.data(), {1.0 / alpha, ((poisson ? p.gain : 0.0) - 1.0) / alpha}, h,
                                 threads);
  if (absl::Status s = control.stop.Check(); !s.ok()) return s;
  if (control.on_progress) {
    Progress progress;
    progress.phase = Phase::kEnhancing;
    control.on_progress(progress);
  }
  std::vector<Vec3> enhanced(n);
  if (absl::Status s = stepper.Step(mesh.positions.data(), enhanced.data(), false); !s.ok()) return s;
  if (!poisson) {
    const std::vector<Vec3> base = std::exchange(enhanced, mesh.positions);
    absl::StatusOr<int> steps =
        InvertedFlow(topo, role.data(), p, mesh.positions.data(), base.data(), h, control, enhanced.data());
    if (!steps.ok()) return steps.status();
    result.inverted_steps = *steps;
  }
  // Three Newton steps a call: a gain that grows the shape by a good share of its size takes a
  // few calls (the volume is cubic in the offset). Before the faces are checked: the offset
  // undoes the growth of the shape's own curvature, which is the enhancement's, and a vertex held
  // back after it would get it all the same, a dent of the whole offset, where one held back
  // before it keeps F; the volume then differs from the input's by the held-back vertices' share
  // of their moves.
  for (int call = 0; closed && call < 4; ++call) {
    job::RestoreVolume(enhanced.data(), topo, role.data(), h, threads, volume, std::numeric_limits<double>::infinity());
  }
  HoldBackTurnedFaces(mesh, topo, input.empty() ? mesh.positions.data() : input.data(), mesh.positions.data(),
                      p.turn_halvings, enhanced, result);
  mesh.positions = std::move(enhanced);
  return result;
}

}  // namespace meshsmooth
