// Shape enhancement: screened-Poisson sharpening (Chuang and Kazhdan 2011) with the cotangent
// operator. With K the cotangent Laplacian and M the mixed Voronoi areas (core/flows/implicit.h),
// the enhanced positions G solve
//
//   (alpha M + K) G = alpha M F + gain K F,     alpha = 2 pi^2 / d^2,
//
// F the input, d the detail scale: a wave of wavelength w along the surface is multiplied by
// (1 + gain (d/w)^2) / (1 + (d/w)^2): by about `gain` below d, (1 + gain) / 2 at d, and not at all
// far above it. One sparse solve (symmetric positive definite for any gain >= 0: stable for every
// gain), the boundary and vertices of strength 0 fixed, a strength between scaling the move. A
// closed mesh then gets its volume back along its normals (a convex shape's own curvature is
// detail too, and would grow with it). Noise is the finest detail and would grow most: a noisy
// input is refused, or smoothed first by the default job (EnhanceParams::smooth_first).
// docs/decisions.md ("Shape enhancement: a subcommand") says why this is `meshsmooth enhance`
// and not a flow.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/flows/catalogue.h"
#include "core/flows/flow.h"
#include "core/mesh.h"
#include "core/topology.h"

namespace meshsmooth {

// The largest gain Enhance takes (100).
double MaxEnhanceGain();

// The fields of the service's JobSpec.enhance ("enhance.gain", ...) with their defaults and
// ranges, as ListFlows and the CLI's help state them. The service takes gains in (1, 100]: a
// gain <= 1 smooths, which the smoothing jobs do.
std::vector<ParameterInfo> EnhanceParameters();

// How Enhance sharpens.
enum class EnhanceMethod {
  // One solve of the screened-Poisson system above: stable for any gain.
  kScreenedPoisson,
  // The paper's proposal (its conclusion: "simple inverting of a smoothing flow is usually
  // unstable; stability can be achieved by a curvature-based local control similar to Section
  // 4"): explicit steps of the umbrella flow run backwards on the band below d. With U the
  // umbrella (eq. 3), B the input smoothed at scale d (the solve above with gain 0) and F the
  // input, a step moves each free vertex by lambda (U(P) - U*), U* = U(B) + gain (U(F) - U(B)):
  // against the smoothing direction by (gain - 1) times the input's band curvature at first, and
  // by less as the vertex's own curvature nears gain times it. Eq. (14)'s local control, turned
  // round: the move of a step is at most lambda T(P), T(P) = gain |U(F) - U(B)| at P, so a vertex
  // without detail of its own does not move. The steps are Jacobi sweeps towards the screened-
  // Poisson solution (I - W has eigenvalues in [0, 2], so lambda < 1 contracts every mode): they
  // stay bounded however many run, and stop once no vertex moves by more than 1e-6 h.
  kInvertedFlow,
};

struct EnhanceParams {
  double gain = 2.0;            // [0, MaxEnhanceGain()]: > 1 sharpens, 1 leaves the mesh, < 1 smooths
  double detail_scale = 0.0;    // d, mesh units; 0 = detail_scale_h x h
  double detail_scale_h = 8.0;  // d in mean edge lengths h of the input when detail_scale is 0
  bool smooth_first = false;    // a noisy input: smoothed by the default job first (else refused)
  std::vector<uint8_t> locked;  // as FlowParams::locked
  std::vector<float> strength;  // as FlowParams::strength
  ImplicitSolver solver = ImplicitSolver::kAuto;
  int threads = 0;  // 0 = all hardware threads
  EnhanceMethod method = EnhanceMethod::kScreenedPoisson;
  int inverted_iterations = 1000;  // kInvertedFlow: the most steps (fewer once converged), >= 1
  double inverted_step = 0.9;      // kInvertedFlow: lambda, in (0, 1)
  int turn_halvings = 4;           // rounds a turned face's vertices' share is halved before it goes to 0
};

struct EnhanceResult {
  double mean_edge_length = 0.0;  // h of the input
  double detail_scale = 0.0;      // d applied, mesh units
  // The default job's run when the input was noisy and EnhanceParams::smooth_first; else unset.
  std::optional<FlowResult> smoothing;
  int inverted_steps = 0;  // kInvertedFlow: the steps run
  // The vertices held back (given less than their whole move) so that no face turns over, and
  // the share of the enhancement's move kept: the RMS of the moves returned over the RMS of the
  // moves enhanced (1 when none was held back).
  int64_t held_back = 0;
  double kept = 1.0;
};

// Enhances `mesh` in place (connectivity unchanged). InvalidArgument for a gain or detail scale
// out of range, a bad strength or lock mask, non-finite coordinates; FailedPrecondition when the
// input is noisy (the default job would smooth it: its estimated noise is named) and
// smooth_first is not set, or when the solve fails. Reports Phase::kEnhancing to
// control.on_progress before the solve. `topo` is lent as Smooth()'s is (flow.h).
//
// No face turns over: sharpening grows the finest detail most, and on needles and thin triangles
// it grows a vertex across its face's far edge. The result is F + t_v (E - F) per vertex, F the
// mesh enhanced (the input, or the input smoothed first), E the enhancement with its volume given
// back, t_v = 1 at first; each round halves t_v at the vertices of every face whose normal turned
// by more than 90 degrees from the input's (NormalFlipped, core/measure/metrics.h: the summary's
// flipped normals) and had not at F, and after turn_halvings rounds sets it to 0 (there the face
// is F's). The same bits for any thread count.
absl::StatusOr<EnhanceResult> Enhance(Mesh& mesh, Topology& topo, const EnhanceParams& p,
                                      const RunControl& control = {});

}  // namespace meshsmooth
