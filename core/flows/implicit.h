// Internal to core/flows and shape enhancement (core/job/enhance.cc): the implicit step of the flows that have one
// (HasImplicitForm, FlowParams::integration; docs/paper.md, "Implicit steps"). Each of them moves a free vertex by a
// speed
// -(K P)_i / M_i, with K a symmetric positive semi-definite operator and M a positive diagonal:
//
//   laplacian U0:  K = L (the ring's graph Laplacian),              M = valence
//   laplacian U1:  K = L_w, w = 1 / |P_i - P_k| (U1's weights),     M = sum of the weights
//   bilaplacian:   K = L D^-1 L (U0^2 = D^-1 L D^-1 L),             M = valence
//   mcf:           K = L_cot (cot alpha + cot beta),                M = 4 x mixed Voronoi area
//
// One step solves (M / s + theta lambda K) d = -lambda K P over the free vertices (d = 0 on the
// others: fixed, boundary, strength 0), s the vertex's strength, then P <- P + d. theta = 0 would
// be the explicit step; theta 1 is backward Euler, 0.5 Crank-Nicolson. U1's and mcf's weights and
// M are taken at the step's start (semi-implicit, Desbrun et al. 1999); U0's and bilaplacian's
// matrix is the same every step. The system is symmetric positive definite: a sparse LDL^T
// (factored once when the matrix is constant) or conjugate gradients preconditioned by its
// diagonal and started from the last step's move. Every sum runs in fixed blocks reduced in
// block order, and the factorisation is sequential: the result is the same for any thread count.
#pragma once

#include <cstdint>
#include <memory>

#include "absl/functional/function_ref.h"
#include "absl/status/status.h"
#include "core/flows/flow.h"
#include "core/topology.h"

namespace meshsmooth::flows {

// ImplicitSolver::kAuto factors the system (kDirect) up to this many free vertices (the meshes
// that run on one thread) and runs conjugate gradients above: bilaplacian's factor on the dragon
// (437,645 vertices) took 22.7 s where CG took 0.4-0.9 s a step (docs/performance.md,
// "Implicit steps").
inline constexpr int32_t kMaxDirectVertices = 20000;

// CG fails after this many iterations (it stops at FlowParams::cg_tolerance), or earlier when
// its largest residual (against its goal) does not halve in a window of kCgStallWindow: the
// tolerance asks for some 50 halvings, so such a solve would not end within the bound anyway.
// It fails at once when p.Ap <= 0 (the matrix is not positive definite).
inline constexpr int kMaxCgIterations = 5000;
inline constexpr int kCgStallWindow = 500;

// Conjugate gradients for A x = b on the three coordinates of n vertices at once, each with its
// own step lengths, preconditioned by `diag` (A's diagonal, > 0): `apply(p, q)` sets q = A p and
// returns p . q per coordinate. On entry x holds the start and r = b - A x; a coordinate is done
// once its r . r <= goal (> 0). Three passes an iteration: q = A p (with p . q), the update of x
// and r (with r . r and r . z), the update of p; every sum in fixed blocks reduced in block
// order. FailedPrecondition on p . Ap <= 0, on a stall (kCgStallWindow), after kMaxCgIterations
// and on a result that is not finite. `iterations` gets the count.
absl::Status ConjugateGradients(int32_t n, int threads, absl::FunctionRef<Vec3(const Vec3*, Vec3*)> apply,
                                const double* diag, const Vec3& goal, Vec3* x, Vec3* r, int* iterations);

// The system of one step: (M / s + lhs K) d = rhs K P. A flow's step at effective step lambda is
// {theta lambda, -lambda}; shape enhancement (core/job/enhance.h) is {1 / alpha, (gain - 1) / alpha}.
struct ImplicitWeights {
  double lhs = 0.0;  // >= 0
  double rhs = 0.0;
};

class ImplicitStepper {
 public:
  // `role` (flow_kernel.h) per vertex: the kFree ones move. `p` gives the operator (its flow, set,
  // and weights), the strength, the solver and CG's tolerance. `h` is the input's mean edge
  // length (U1's floor on a distance, CG's floor on a residual).
  ImplicitStepper(const Topology& topo, const FlowParams& p, const uint8_t* role, ImplicitWeights weights, double h,
                  int threads);
  ~ImplicitStepper();

  // One step from `cur` into `next` (every vertex written; those that do not move copy `cur`).
  // `next` may hold the positions before `cur` (the driver's double buffer) when
  // `next_holds_previous`: CG then starts from that step's move. FailedPrecondition when the
  // factorisation fails or CG does not converge.
  absl::Status Step(const Vec3* cur, Vec3* next, bool next_holds_previous);

  // The solver this run uses (kDirect or kCg), and the CG iterations of the last step (0 direct).
  ImplicitSolver solver() const;
  int last_cg_iterations() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshsmooth::flows
