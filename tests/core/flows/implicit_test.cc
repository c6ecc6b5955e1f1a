// Implicit steps (FlowParams::integration): backward Euler shrinks a sphere as the discrete
// operator's eigenvalue says, Crank-Nicolson is second order in the step against the exact
// solution of the same linear flow, both solvers agree, strength 0 and the boundary hold, the
// result is the same for any thread count, a large step stays stable, a bad job is refused, and
// conjugate gradients fail with a reason on the systems they cannot solve.
#include <Eigen/Dense>
#include <cmath>
#include <cstring>
#include <string>
#include <tuple>
#include <vector>

#include "core/flows/catalogue.h"
#include "core/flows/flow.h"
#include "core/flows/implicit.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/bump_sphere.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

FlowParams Implicit(const std::string& flow, int iterations, double step, double theta = 1.0,
                    ImplicitSolver solver = ImplicitSolver::kAuto) {
  FlowParams p = Params(flow, iterations, step);
  p.integration = Integration::kImplicit;
  p.theta = theta;
  p.implicit_solver = solver;
  p.cg_tolerance = 1e-12;  // the tests compare CG's results with closed forms and the direct solver's
  return p;
}

Mesh Scaled(Mesh m, double r) {
  for (Vec3& p : m.positions) p *= r;
  return m;
}

double MaxDistance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double d = 0.0;
  for (size_t v = 0; v < a.size(); ++v) d = std::max(d, Norm(a[v] - b[v]));
  return d;
}

// The sphere of radius r with a bump eps Re((x + i y)^l) along the normal: a spherical harmonic
// of degree l.
Mesh HarmonicSphere(int level, double r, int l, double eps) {
  Mesh m = Icosphere(level);
  for (Vec3& p : m.positions) {
    double re = 1.0, im = 0.0;
    for (int k = 0; k < l; ++k) {
      const double next = re * p.x - im * p.y;
      im = re * p.y + im * p.x;
      re = next;
    }
    p = p * (r * (1.0 + eps * re));
  }
  return m;
}

// On the icosahedron every vertex is alike, so P is an eigenvector of the cotangent operator:
// H n = -(|H n| / r) P, K P = M (|H n| / r) P, and one backward-Euler step solves
// (M + lambda K) P' = M P: r' = r / (1 + lambda |H n| / r), for any step.
TEST(ImplicitTest, BackwardEulerShrinksTheIcosahedronByItsEigenvalue) {
  for (ImplicitSolver solver : {ImplicitSolver::kDirect, ImplicitSolver::kCg}) {
    for (double r : {1.0, 0.01, 100.0}) {
      for (double step : {0.1, 1.0, 1000.0}) {
        SCOPED_TRACE(::testing::Message() << "solver " << static_cast<int>(solver) << " r " << r << " step " << step);
        Mesh m = Scaled(Icosphere(0), r);
        Topology topo = BuildTopology(m);
        const double h = MeanEdgeLength(m, topo);
        const double hn = Norm(MeanCurvatureNormals(m, topo)[0]);
        const double lambda = step * h * h;
        const double predicted = r / (1.0 + lambda * hn / r);
        ASSERT_TRUE(Smooth(m, topo, Implicit("mcf", 1, step, 1.0, solver)).ok());
        for (const Vec3& p : m.positions) EXPECT_NEAR(Norm(p), predicted, 1e-6 * predicted);
        // The discrete eigenvalue is close to the sphere's 2 / r^2 (an icosahedron is coarse).
        EXPECT_NEAR(hn * r, 1.0, 0.25);
      }
    }
  }
}

// dP/dt = U0 P is linear with a constant matrix: its exact solution is exp(t U0) P0 (U0 = D^-1 A - I
// is similar to the symmetric D^-1/2 A D^-1/2 - I). On a sphere with a degree-3 harmonic bump,
// Crank-Nicolson's error at t = 2 falls 4 times when the step halves; backward Euler's 2 times.
TEST(ImplicitTest, CrankNicolsonIsSecondOrderBackwardEulerFirst) {
  const Mesh start = HarmonicSphere(2, 1.0, 3, 0.1);
  Topology topo = BuildTopology(start);
  const int32_t n = start.num_vertices();
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd sqrt_d(n);
  for (int32_t v = 0; v < n; ++v) sqrt_d(v) = std::sqrt(static_cast<double>(topo.valence(v)));
  for (int32_t v = 0; v < n; ++v) {
    for (int32_t i = topo.ring_offsets[v]; i < topo.ring_offsets[v + 1]; ++i) {
      s(v, topo.ring[i]) = 1.0 / (sqrt_d(v) * sqrt_d(topo.ring[i]));
    }
    s(v, v) -= 1.0;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(s);
  const double t = 2.0;
  Eigen::MatrixXd p0(n, 3);
  for (int32_t v = 0; v < n; ++v) p0.row(v) << start.positions[v].x, start.positions[v].y, start.positions[v].z;
  const Eigen::VectorXd decay = (eig.eigenvalues() * t).array().exp();
  const Eigen::MatrixXd exact = sqrt_d.cwiseInverse().asDiagonal() * eig.eigenvectors() * decay.asDiagonal() *
                                eig.eigenvectors().transpose() * sqrt_d.asDiagonal() * p0;
  std::vector<Vec3> exact_pos(n);
  for (int32_t v = 0; v < n; ++v) exact_pos[v] = {exact(v, 0), exact(v, 1), exact(v, 2)};

  for (double theta : {0.5, 1.0}) {
    std::vector<double> error;
    for (int steps : {4, 8, 16, 32}) {
      Mesh m = start;
      ASSERT_TRUE(Smooth(m, topo, Implicit("laplacian", steps, t / steps, theta)).ok());
      error.push_back(MaxDistance(m.positions, exact_pos));
    }
    for (size_t k = 1; k < error.size(); ++k) {
      const double ratio = error[k - 1] / error[k];
      SCOPED_TRACE(::testing::Message() << "theta " << theta << " halving " << k << " error " << error[k]);
      if (theta == 0.5) {
        EXPECT_NEAR(ratio, 4.0, 0.3);
      } else {
        EXPECT_NEAR(ratio, 2.0, 0.3);
      }
    }
  }
}

// Both solvers solve the same system: CG's result is the direct one's within its tolerance, for
// every flow with an implicit form, with strengths between 0 and 1.
TEST(ImplicitTest, DirectAndConjugateGradientsAgree) {
  const Mesh noisy = NoisySphere(4);
  Topology topo = BuildTopology(noisy);
  const double h = MeanEdgeLength(noisy, topo);
  std::vector<float> strength(noisy.num_vertices());
  for (int32_t v = 0; v < noisy.num_vertices(); ++v) strength[v] = 0.25f + 0.75f * static_cast<float>(v % 4) / 3.0f;
  for (const auto& [flow, weights, step] :
       {std::tuple{"laplacian", UmbrellaWeights::kUniform, 2.0},
        std::tuple{"laplacian", UmbrellaWeights::kInverseDistance, 2.0},
        std::tuple{"bilaplacian", UmbrellaWeights::kUniform, 1.0}, std::tuple{"mcf", UmbrellaWeights::kUniform, 1.0}}) {
    SCOPED_TRACE(::testing::Message() << flow << " weights " << static_cast<int>(weights));
    Mesh direct = noisy, cg = noisy;
    FlowParams p = Implicit(flow, 3, step, 1.0, ImplicitSolver::kDirect);
    p.weights = weights;
    p.strength = strength;
    ASSERT_TRUE(Smooth(direct, topo, p).ok());
    p.implicit_solver = ImplicitSolver::kCg;
    ASSERT_TRUE(Smooth(cg, topo, p).ok());
    EXPECT_LT(MaxDistance(direct.positions, cg.positions), 1e-7 * h);
    EXPECT_GT(MaxDistance(direct.positions, noisy.positions), 0.1 * h) << "nothing moved";
  }
}

// A small implicit step is the explicit step to first order: the two differ by O(step^2).
TEST(ImplicitTest, SmallStepsAgreeWithTheExplicitFlow) {
  const Mesh noisy = NoisySphere(3);
  Topology topo = BuildTopology(noisy);
  for (const std::string flow : {"laplacian", "bilaplacian", "mcf"}) {
    std::vector<double> gap;
    for (double step : {0.02, 0.01}) {
      Mesh ex = noisy, im = noisy;
      ASSERT_TRUE(Smooth(ex, topo, Params(flow, 1, step)).ok());
      ASSERT_TRUE(Smooth(im, topo, Implicit(flow, 1, step)).ok());
      gap.push_back(MaxDistance(ex.positions, im.positions));
    }
    SCOPED_TRACE(flow);
    EXPECT_NEAR(gap[0] / gap[1], 4.0, 0.4);
  }
}

// Strength 0 keeps every bit, as does a fixed boundary; the rest moves.
TEST(ImplicitTest, StrengthZeroAndTheBoundaryDoNotMove) {
  const Mesh noisy = NoisySphere(4);
  Topology topo = BuildTopology(noisy);
  std::vector<float> strength(noisy.num_vertices(), 1.0f);
  for (int32_t v = 0; v < noisy.num_vertices(); ++v) strength[v] = noisy.positions[v].z > 0.3 ? 0.0f : 1.0f;
  Mesh sheet = CosineHeightField(0.1, 2, 8, 32);
  AddUniformNoise(sheet, 0.3, 7);
  Topology sheet_topo = BuildTopology(sheet);
  for (const std::string flow : {"laplacian", "bilaplacian", "mcf"}) {
    for (ImplicitSolver solver : {ImplicitSolver::kDirect, ImplicitSolver::kCg}) {
      SCOPED_TRACE(::testing::Message() << flow << " solver " << static_cast<int>(solver));
      Mesh out = noisy;
      FlowParams p = Implicit(flow, 2, 5.0, 1.0, solver);
      p.strength = strength;
      ASSERT_TRUE(Smooth(out, topo, p).ok());
      int32_t moved = 0;
      for (int32_t v = 0; v < noisy.num_vertices(); ++v) {
        if (strength[v] == 0.0f) {
          ASSERT_EQ(std::memcmp(&out.positions[v], &noisy.positions[v], sizeof(Vec3)), 0) << "vertex " << v;
        } else {
          moved += !(out.positions[v] == noisy.positions[v]);
        }
      }
      EXPECT_GT(moved, noisy.num_vertices() / 2);
      Mesh open = sheet;
      ASSERT_TRUE(Smooth(open, sheet_topo, Implicit(flow, 2, 5.0, 1.0, solver)).ok());
      for (int32_t v = 0; v < sheet.num_vertices(); ++v) {
        if (sheet_topo.kind[v] != VertexKind::kBoundary) continue;
        ASSERT_EQ(std::memcmp(&open.positions[v], &sheet.positions[v], sizeof(Vec3)), 0) << "boundary vertex " << v;
      }
    }
  }
}

// Above the parallel threshold (20,000 vertices) the loops run on every thread: the same bits
// with one thread and with four.
TEST(ImplicitTest, SameBitsForAnyThreadCount) {
  const Mesh noisy = NoisySphere(6);
  Topology topo = BuildTopology(noisy);
  for (const std::string flow : {"laplacian", "bilaplacian", "mcf"}) {
    for (ImplicitSolver solver : {ImplicitSolver::kDirect, ImplicitSolver::kCg}) {
      SCOPED_TRACE(::testing::Message() << flow << " solver " << static_cast<int>(solver));
      Mesh one = noisy, four = noisy;
      FlowParams p = Implicit(flow, 2, 3.0, 0.5, solver);
      p.threads = 1;
      ASSERT_TRUE(Smooth(one, topo, p).ok());
      p.threads = 4;
      ASSERT_TRUE(Smooth(four, topo, p).ok());
      ASSERT_EQ(std::memcmp(one.positions.data(), four.positions.data(), one.positions.size() * sizeof(Vec3)), 0);
    }
  }
}

// Steps hundreds of times the explicit bound: backward Euler stays finite and smooths.
TEST(ImplicitTest, LargeStepsAreStable) {
  const Mesh noisy = NoisySphere(4);
  Topology topo = BuildTopology(noisy);
  for (const auto& [flow, step] :
       {std::pair{"laplacian", 1000.0}, std::pair{"bilaplacian", 500.0}, std::pair{"mcf", 100.0}}) {
    SCOPED_TRACE(flow);
    Mesh out = noisy;
    const absl::StatusOr<FlowResult> r = Smooth(out, topo, Implicit(flow, 1, step));
    ASSERT_TRUE(r.ok()) << r.status();
    for (const Vec3& q : out.positions) ASSERT_TRUE(IsFinite(q));
    EXPECT_LT(RadiusError(out), 0.5 * RadiusError(noisy));
  }
}

// Needles whose angles are 2e-5, 2e-5 and 180 degrees less both: their cotangents exceed
// kCotMax. Clamped one by one (+kCotMax, +kCotMax, -kCotMax) each needle's stiffness would be
// indefinite, and so the system: CG stalls and the factorisation solves a wrong system. Scaled
// together it stays semi-definite, and the step is the plain icosphere's: the needles split its
// faces in their own plane, and the same lambda (step h^2) shrinks both alike.
TEST(ImplicitTest, NeedleTrianglesKeepTheSystemPositiveDefinite) {
  const Mesh plain = Icosphere(3), needles = SphereWithNeedles(1e-5);
  Topology plain_topo = BuildTopology(plain), topo = BuildTopology(needles);
  const double h_plain = MeanEdgeLength(plain, plain_topo), h = MeanEdgeLength(needles, topo);
  for (double step : {1.8, 100.0}) {
    Mesh reference = plain;
    ASSERT_TRUE(Smooth(reference, plain_topo, Implicit("mcf", 1, step)).ok());
    const double shrunk = Volume(reference) / Volume(plain);
    for (ImplicitSolver solver : {ImplicitSolver::kDirect, ImplicitSolver::kCg}) {
      SCOPED_TRACE(::testing::Message() << "step " << step << " solver " << static_cast<int>(solver));
      Mesh out = needles;
      const absl::StatusOr<FlowResult> r =
          Smooth(out, topo, Implicit("mcf", 1, step * (h_plain * h_plain) / (h * h), 1.0, solver));
      ASSERT_TRUE(r.ok()) << r.status();
      for (const Vec3& q : out.positions) ASSERT_TRUE(IsFinite(q));
      EXPECT_EQ(FlippedFaces(needles, out), 0);
      EXPECT_NEAR(Volume(out) / Volume(needles), shrunk, 0.01 * (1.0 - shrunk));
      double worst = 0.0;  // the plain icosphere's vertices, in both
      for (size_t v = 0; v < plain.positions.size(); ++v) {
        worst = std::max(worst, std::abs(Norm(out.positions[v]) - Norm(reference.positions[v])));
      }
      EXPECT_LT(worst, 0.05 * (1.0 - std::cbrt(shrunk)));  // 2% measured; 170% with the clamped needles
    }
  }
}

TEST(ImplicitTest, BadJobsAreRefusedWithAReason) {
  Mesh m = NoisySphere(2);
  auto refused = [&](const FlowParams& p, const std::string& words) {
    Mesh copy = m;
    const absl::StatusOr<FlowResult> r = Smooth(copy, p);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(r.status().message()).find(words), std::string::npos) << r.status().message();
  };
  refused(Implicit("median", 1, 0.1), "median has no implicit form");
  refused(Implicit("taubin", 1, 0.1), "taubin has no implicit form");
  refused(Implicit("bilateral_normal", 1, 0.1), "no implicit form");
  refused(Implicit("laplacian", 1, 1.0, 0.3), "theta must be in [0.5, 1]");
  refused(Implicit("laplacian", 1, 2e6), "step must be in (0, 1e+06] for implicit laplacian");
  FlowParams adaptive = Implicit("mcf", 1, 1.0);
  adaptive.adaptive = AdaptiveMode::kRing1;
  refused(adaptive, "no adaptive threshold");
  FlowParams curve = Implicit("mcf", 1, 1.0);
  curve.boundary = BoundaryMode::kCurve;
  refused(curve, "boundary curve is explicit only");
  FlowParams choosing;
  choosing.integration = Integration::kImplicit;
  refused(choosing, "implicit integration needs a flow");
  // The explicit bound does not apply to an implicit step.
  Mesh copy = m;
  EXPECT_TRUE(Smooth(copy, Implicit("bilaplacian", 1, 50.0)).ok());
}

// Conjugate gradients on A x = b with A = `diagonal` on the diagonal and -1 between the
// neighbours of a path of n vertices (2 + eps: a 1D Laplacian plus a mass eps, definite; -2.5:
// negative definite), the same b on the three coordinates, x from 0, to the relative residual 1e-8.
absl::Status PathCg(int32_t n, double diagonal, const std::vector<double>& b, int* iterations) {
  const std::vector<double> diag(n, diagonal);
  std::vector<Vec3> x(n), r(n);
  double b2 = 0.0;
  for (int32_t v = 0; v < n; ++v) r[v] = {b[v], b[v], b[v]}, b2 += b[v] * b[v];
  auto apply = [&](const Vec3* p, Vec3* q) {
    Vec3 dot;
    for (int32_t v = 0; v < n; ++v) {
      q[v] = p[v] * diagonal;
      if (v > 0) q[v] -= p[v - 1];
      if (v + 1 < n) q[v] -= p[v + 1];
      dot += Vec3{p[v].x * q[v].x, p[v].y * q[v].y, p[v].z * q[v].z};
    }
    return dot;
  };
  const double goal = 1e-16 * b2;
  return flows::ConjugateGradients(n, 1, apply, diag.data(), {goal, goal, goal}, x.data(), r.data(), iterations);
}

void ExpectFailure(const absl::Status& s, const std::string& message) {
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition) << s;
  EXPECT_EQ(s.message(), message);
}

// The iteration counts and residuals below are those of the same iteration in double precision
// (a NumPy model gives the same figures).
TEST(ImplicitTest, ConjugateGradientsFailWithAReason) {
  const int32_t n = 20000;
  std::vector<double> first(n, 0.0);
  first[0] = 1.0;
  const std::vector<double> ones(n, 1.0);
  int iterations = -1;
  // eps = 1e-5, b = e_0: it converges, the squared residual falling some 24x in every window.
  ASSERT_TRUE(PathCg(n, 2.0 + 1e-5, first, &iterations).ok());
  EXPECT_GT(iterations, 4 * flows::kCgStallWindow);
  EXPECT_LT(iterations, flows::kMaxCgIterations);
  // Negative definite: p = r / diag = e_0 / -2.5 and p.Ap = -0.4 at once.
  ExpectFailure(PathCg(n, -2.5, first, &iterations),
                "the implicit step's matrix is not positive definite (conjugate gradients met p.Ap = -0.4 at "
                "iteration 0)");
  EXPECT_EQ(iterations, 0);
  // eps = 1e-6, b = 1: the best squared residual of the first window is some 250x the start's (it grows
  // while the smooth part of x builds up), so the solve stops after kCgStallWindow iterations.
  ExpectFailure(PathCg(n, 2.0 + 1e-6, ones, &iterations),
                "the implicit step's conjugate gradients stopped converging (the residual did not halve in 500 "
                "iterations, 500 in all); try a smaller step");
  // eps = 3e-6, b = e_0: the squared residual falls 6-8x in every window, too slowly for 1e-8 within
  // kMaxCgIterations.
  ExpectFailure(PathCg(n, 2.0 + 3e-6, first, &iterations),
                "the implicit step's conjugate gradients did not converge in 5000 iterations; try a smaller step");
  EXPECT_EQ(iterations, flows::kMaxCgIterations);
}

// With automatic iterations an implicit run goes through the default job's rule: it stops at its
// least estimated error and a closed mesh gets its volume back, as an explicit run does.
TEST(ImplicitTest, AutomaticIterationsKeepTheVolume) {
  const Mesh noisy = NoisySphere(4);
  for (bool implicit : {false, true}) {
    SCOPED_TRACE(implicit ? "implicit" : "explicit");
    Mesh out = noisy;
    FlowParams p = Params("bilaplacian", kAutoIterations, implicit ? 2.0 : 0.2);
    if (implicit) p.integration = Integration::kImplicit;
    const absl::StatusOr<FlowResult> r = Smooth(out, p);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_GT(r->iterations_run, 0);
    EXPECT_LT(RadiusError(out), 0.5 * RadiusError(noisy));
    EXPECT_NEAR(Volume(out) / Volume(noisy), 1.0, 1e-4);
  }
}

}  // namespace
}  // namespace meshsmooth
