// The face-normal measures (core/measure/normal_turn.h) and the discrepancy rule
// (TurnStop, core/job/rules.h) against closed forms.

#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

#include "core/flows/flow_kernel.h"
#include "core/job/rules.h"
#include "core/measure/noise.h"
#include "core/measure/normal_turn.h"
#include "core/mesh.h"
#include "core/topology.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

// A flat sheet of equilateral triangles of side `a`, `n` by `n` vertices, in the plane z = 0;
// `fold` > 0 bends it along the line x = x_mid so that its two halves meet at that dihedral
// angle's supplement (the faces' normals `fold` radians apart).
Mesh EquilateralSheet(int n, double a, double fold = 0.0) {
  Mesh m;
  const double row = a * std::sqrt(3.0) / 2.0;
  const double mid = 0.5 * a * (n - 1);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      double x = a * i + (j % 2 == 1 ? 0.5 * a : 0.0), z = 0.0;
      if (fold > 0.0 && x > mid) {  // rotate the right half about the line x = mid
        const double d = x - mid;
        x = mid + d * std::cos(fold);
        z = d * std::sin(fold);
      }
      m.positions.push_back({x, row * j, z});
    }
  }
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const int v = j * n + i, up = (j + 1) * n + i;
      if (j % 2 == 0) {
        m.triangles.push_back({v, v + 1, up});
        m.triangles.push_back({v + 1, up + 1, up});
      } else {
        m.triangles.push_back({v, up + 1, up});
        m.triangles.push_back({v, v + 1, up + 1});
      }
    }
  }
  return m;
}

// Independent offsets of deviation sigma along the normal of a flat sheet of equilateral
// triangles of side a tilt each face by the gradient of the offsets' linear interpolation: a
// two-dimensional Gaussian of deviation sigma sqrt(2) / a per axis, whose mean length is
// sigma sqrt(pi) / a.
TEST(DiscrepancyTest, PredictedNormalNoiseOfAFlatSheetIsTheClosedForm) {
  const double a = 2.0;
  const Mesh sheet = EquilateralSheet(80, a);
  const Topology topo = BuildTopology(sheet);
  for (double sigma : {0.005, 0.01, 0.02}) {
    const double expected = sigma * std::sqrt(std::numbers::pi) / a;
    const double predicted = PredictedNormalNoise(sheet, topo, sigma);
    EXPECT_NEAR(predicted / expected, 1.0, 0.02) << sigma;
  }
  // The same offsets on triangles half as wide turn them twice as far.
  const Mesh fine = EquilateralSheet(80, a / 2.0);
  EXPECT_NEAR(PredictedNormalNoise(fine, BuildTopology(fine), 0.01) / PredictedNormalNoise(sheet, topo, 0.01), 2.0,
              0.05);
}

// A rigid rotation by alpha turns every face by alpha.
TEST(DiscrepancyTest, NormalTurnOfARotationIsItsAngle) {
  const Mesh sheet = EquilateralSheet(20, 1.0);
  const Topology topo = BuildTopology(sheet);
  const NormalTurn turn(sheet, topo);
  EXPECT_DOUBLE_EQ(turn.Of(sheet.positions.data()), 0.0);
  for (double alpha : {0.01, 0.3, 1.0}) {
    std::vector<Vec3> rotated;
    for (const Vec3& p : sheet.positions) {
      rotated.push_back(
          {p.x, p.y * std::cos(alpha) - p.z * std::sin(alpha), p.y * std::sin(alpha) + p.z * std::cos(alpha)});
    }
    EXPECT_NEAR(turn.Of(rotated.data()), alpha, 1e-9) << alpha;
  }
}

// A sheet of n by n vertices on a square grid of side 1, each square cut by a diagonal, bent by
// `fold` radians along the grid line x = n / 2 (a line of edges).
Mesh FoldedSquareSheet(int n, double fold) {
  Mesh m;
  const double mid = n / 2;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double d = i - mid;
      m.positions.push_back(d > 0 ? Vec3{mid + d * std::cos(fold), double(j), d * std::sin(fold)}
                                  : Vec3{double(i), double(j), 0.0});
    }
  }
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const int v = j * n + i, up = v + n;
      m.triangles.push_back({v, v + 1, up + 1});
      m.triangles.push_back({v, up + 1, up});
    }
  }
  return m;
}

// A flat sheet has no normal variation; one folded by beta along a line of edges of length L has
// L |n1 - n2| = L 2 sin(beta / 2): a crease costs its angle and length, nothing else.
TEST(DiscrepancyTest, NormalVariationOfAFoldIsItsLengthTimesTheNormalsGap) {
  const Mesh flat = FoldedSquareSheet(21, 0.0);
  EXPECT_NEAR(NormalVariation(flat.positions.data(), BuildTopology(flat)), 0.0, 1e-12);
  for (double beta : {0.1, 0.5, 1.5}) {
    const Mesh folded = FoldedSquareSheet(21, beta);
    // The fold line x = 10 is 20 edges, each between two faces.
    EXPECT_NEAR(NormalVariation(folded.positions.data(), BuildTopology(folded)), 20.0 * 2.0 * std::sin(beta / 2.0),
                1e-9)
        << beta;
  }
}

// The rule stops with noise_removed at the first iteration whose turn reaches the target, and
// with converged when the turn stops growing short of it.
TEST(DiscrepancyTest, StopsOnceTheFacesTurnedByTheTarget) {
  const Mesh sheet = EquilateralSheet(20, 1.0);
  const Topology topo = BuildTopology(sheet);
  auto rotated = [&](double alpha) {
    std::vector<Vec3> out;
    for (const Vec3& p : sheet.positions) {
      out.push_back(
          {p.x, p.y * std::cos(alpha) - p.z * std::sin(alpha), p.y * std::sin(alpha) + p.z * std::cos(alpha)});
    }
    return out;
  };
  const NoiseEstimate noise;
  const std::vector<uint8_t> role(sheet.num_vertices(), flows::kFree);
  job::TurnStop rule(1.0, noise, job::kPolicy, /*target=*/0.1, /*rims=*/false);
  EXPECT_EQ(rule.Start(sheet, topo, role.data(), 1), std::nullopt);
  int stopped = 0;
  std::optional<StopReason> reason;
  for (int it = 1; it <= 20 && !reason; ++it) {
    reason = rule.After(it, rotated(0.011 * it).data(), nullptr);
    stopped = it;
  }
  EXPECT_EQ(reason, StopReason::kNoiseRemoved);
  EXPECT_EQ(stopped, 10);  // 0.110 >= 0.1 > 0.099
  job::TurnStop slow(1.0, noise, job::kPolicy, 0.1, false);
  slow.Start(sheet, topo, role.data(), 1);
  reason.reset();
  for (int it = 1; it <= 40 && !reason; ++it) {
    reason = slow.After(it, rotated(0.05 * (1.0 - std::pow(0.5, it))).data(), nullptr);  // levels off at 0.05
    stopped = it;
  }
  EXPECT_EQ(reason, StopReason::kConverged);
  EXPECT_EQ(stopped, 2 * job::kPolicy.patience);  // the first iteration the rule may call it
}

}  // namespace
}  // namespace meshsmooth
