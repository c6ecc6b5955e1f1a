// The range-scan simulator (bench/range_scan.h): one test per property of the sensor model,
// each on a scene whose answer is known in closed form (planes in front of the camera).
#include "bench/range_scan.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <vector>

#include "gtest/gtest.h"

namespace meshsmooth::bench {
namespace {

// A square of side `side` centred on `centre`, spanned by unit vectors a and b, as an n x n grid.
Mesh Square(const Vec3& centre, const Vec3& a, const Vec3& b, double side, int n = 8) {
  Mesh m;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      m.positions.push_back(centre + (side * (i / double(n) - 0.5)) * a + (side * (j / double(n) - 0.5)) * b);
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const int32_t v = j * (n + 1) + i;
      m.triangles.push_back({v, v + 1, v + n + 2});
      m.triangles.push_back({v, v + n + 2, v + n + 1});
    }
  }
  return m;
}

void Append(Mesh& to, const Mesh& from) {
  const int32_t base = to.num_vertices();
  to.positions.insert(to.positions.end(), from.positions.begin(), from.positions.end());
  for (Triangle t : from.triangles) to.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
}

// A camera at the origin looking down +z, as the sensor's image.
Camera Front(const SensorModel& s) {
  return Camera::LookAt({0, 0, 0}, {0, 0, 1}, {0, -1, 0}, s.width, s.height, s.focal_px);
}

// The sensor with only axial noise of the model's deviation: no jitter, no quantization.
SensorModel AxialOnly(SensorModel s) {
  s.lateral_a = s.lateral_b = 0.0;
  s.depth_step = 0.0;
  s.disparity_step_px = 0.0;
  return s;
}

// Per vertex of `frame`, the measured depth minus the clean depth on the same pixel.
std::vector<double> DepthErrors(const RangeMesh& frame, const DepthImage& clean, const Camera& cam) {
  std::vector<double> e;
  for (int32_t v = 0; v < frame.mesh.num_vertices(); ++v) {
    e.push_back(cam.Depth(frame.mesh.positions[v]) - clean.depth[frame.pixel[v]]);
  }
  return e;
}

double Rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

// The error lies along each pixel's ray: its component across the ray is at least 1000 times
// smaller (rounding only). On a plane tilted 50 degrees, noise along the surface normal would
// put sin(50) = 77% of it across the ray.
TEST(RangeScanTest, NoiseLiesAlongTheViewRay) {
  for (const SensorModel& s : {SensorModel::StructuredLight(), SensorModel::TimeOfFlight()}) {
    const Camera cam = Front(s);
    const double c = std::cos(50 * std::numbers::pi / 180), sn = std::sin(50 * std::numbers::pi / 180);
    const Mesh plane = Square({0, 0, 1.0}, {c, 0, sn}, {0, 1, 0}, 0.4);
    const DepthImage clean = RenderDepth(plane, cam);
    const RangeMesh frame = SimulateFrame(plane, cam, s, 7);
    ASSERT_GT(frame.mesh.num_vertices(), 5000) << s.name;
    double along2 = 0.0, across2 = 0.0;
    for (int32_t v = 0; v < frame.mesh.num_vertices(); ++v) {
      const Vec3 ray = cam.Ray(frame.pixel[v]);
      const Vec3 d = frame.mesh.positions[v] - (cam.eye + clean.depth[frame.pixel[v]] * ray);
      const Vec3 dir = Normalized(ray);
      const double along = Dot(d, dir);
      along2 += along * along;
      across2 += SquaredNorm(d - along * dir);
    }
    EXPECT_GT(along2, 0.0) << s.name;
    EXPECT_LT(std::sqrt(across2), 1e-3 * std::sqrt(along2)) << s.name;
  }
}

// Time of flight: every depth is a whole number of millimetres. Structured light: every
// disparity f b / z is a whole number of 1/8 pixels, and the depth steps between neighbouring
// levels grow as z^2 / (8 f b).
TEST(RangeScanTest, DepthIsQuantizedAsConfigured) {
  {
    const SensorModel s = SensorModel::TimeOfFlight();
    const Camera cam = Front(s);
    const Mesh plane = Square({0, 0, 1.2}, Normalized(Vec3{1, 0, 0.6}), {0, 1, 0}, 0.6);
    const RangeMesh frame = SimulateFrame(plane, cam, s, 3);
    ASSERT_GT(frame.mesh.num_vertices(), 1000);
    std::set<long> levels;
    for (const Vec3& p : frame.mesh.positions) {
      const double mm = cam.Depth(p) * 1000.0;
      ASSERT_NEAR(mm, std::round(mm), 1e-6);
      levels.insert(std::lround(mm));
    }
    EXPECT_GT(levels.size(), 100u);  // the tilted plane spans many millimetres
  }
  {
    const SensorModel s = SensorModel::StructuredLight();
    const Camera cam = Front(s);
    const double fb = s.focal_px * s.baseline;
    // A plane receding from 0.8 m to about 2.2 m: the steps at both ends.
    const Mesh plane = Square({0, 0, 1.5}, Normalized(Vec3{1, 0, 2.2}), {0, 1, 0}, 1.6);
    const RangeMesh frame = SimulateFrame(plane, cam, s, 3);
    ASSERT_GT(frame.mesh.num_vertices(), 1000);
    std::set<double> depths;
    for (const Vec3& p : frame.mesh.positions) {
      const double z = cam.Depth(p), d8 = 8.0 * fb / z;
      ASSERT_NEAR(d8, std::round(d8), 1e-6);
      depths.insert(z);
    }
    const std::vector<double> z(depths.begin(), depths.end());
    ASSERT_GT(z.size(), 50u);
    for (size_t i = 1; i < z.size(); ++i) {
      const double mid = 0.5 * (z[i] + z[i - 1]), step = mid * mid / (8.0 * fb);
      EXPECT_NEAR(z[i] - z[i - 1], step, 0.02 * step) << "at " << mid << " m";
    }
    EXPECT_GT(z.back(), 2.0);
    EXPECT_LT(z.front(), 1.0);
  }
}

// The axial deviation measured on fronto-parallel planes at 0.6, 1.2, 1.8 and 2.4 m is the
// model's sigma_z(z, 0) within 8% (about 20,000 pixels each at 1.2 m and beyond), and grows.
TEST(RangeScanTest, DeviationGrowsWithDepthAsConfigured) {
  for (SensorModel s : {SensorModel::StructuredLight(), SensorModel::TimeOfFlight()}) {
    s = AxialOnly(s);
    s.correlation_px = 0.0;  // independent pixels: the sample deviation is sharp
    const Camera cam = Front(s);
    double previous = 0.0;
    for (double z : {0.6, 1.2, 1.8, 2.4}) {
      const Mesh plane = Square({0, 0, z}, {1, 0, 0}, {0, 1, 0}, 0.25 * z);
      const DepthImage clean = RenderDepth(plane, cam);
      const RangeMesh frame = SimulateFrame(plane, cam, s, 11);
      ASSERT_GT(frame.mesh.num_vertices(), 5000) << s.name << " at " << z;
      const double measured = Rms(DepthErrors(frame, clean, cam)), model = s.SigmaZ(z, 0.0);
      EXPECT_NEAR(measured, model, 0.08 * model) << s.name << " at " << z << " m";
      EXPECT_GT(measured, previous) << s.name << " at " << z << " m";
      previous = measured;
    }
  }
}

// The axial noise's autocorrelation along image rows falls to 1/e at the configured length,
// within 15%, for a few lengths.
TEST(RangeScanTest, CorrelationLengthIsAsConfigured) {
  for (double length : {2.0, 5.2, 8.0}) {
    SensorModel s = AxialOnly(SensorModel::StructuredLight());
    s.correlation_px = length;
    const Camera cam = Front(s);
    const Mesh plane = Square({0, 0, 1.0}, {1, 0, 0}, {0, 1, 0}, 0.9);
    const DepthImage clean = RenderDepth(plane, cam);
    const DepthImage measured = MeasureDepth(clean, plane, cam, s, 5);
    std::vector<double> ac;
    for (int lag = 0; lag <= 20; ++lag) {
      double sum = 0.0;
      int64_t n = 0;
      for (int y = 0; y < s.height; ++y) {
        for (int x = 0; x + lag < s.width; ++x) {
          const size_t i = static_cast<size_t>(y) * s.width + x, j = i + lag;
          if (measured.depth[i] <= 0.0 || measured.depth[j] <= 0.0) continue;
          sum += (measured.depth[i] - clean.depth[i]) * (measured.depth[j] - clean.depth[j]);
          ++n;
        }
      }
      ASSERT_GT(n, 100000);
      ac.push_back(sum / static_cast<double>(n));
    }
    double crossing = NAN;
    for (int lag = 1; lag < static_cast<int>(ac.size()); ++lag) {
      const double a = ac[lag - 1] / ac[0], b = ac[lag] / ac[0], e = std::exp(-1.0);
      if (a >= e && b < e) {
        crossing = lag - 1 + (a - e) / (a - b);
        break;
      }
    }
    EXPECT_NEAR(crossing, length, 0.15 * length) << "configured " << length << " px";
  }
}

// Two parallel squares 0.2 m apart, the nearer covering part of the farther: every triangle has
// its three corners on one of them, both are scanned, and the pixels beside the step are dropped.
TEST(RangeScanTest, NoTriangleSpansADepthJump) {
  for (const SensorModel& s : {SensorModel::StructuredLight(), SensorModel::TimeOfFlight()}) {
    const Camera cam = Front(s);
    Mesh scene = Square({0, 0, 1.0}, {1, 0, 0}, {0, 1, 0}, 0.6);
    Append(scene, Square({-0.1, 0, 0.8}, {1, 0, 0}, {0, 1, 0}, 0.3));
    const RangeMesh frame = SimulateFrame(scene, cam, s, 9);
    int near = 0, far = 0;
    for (const Triangle& t : frame.mesh.triangles) {
      int on_near = 0;
      for (int32_t v : t) on_near += cam.Depth(frame.mesh.positions[v]) < 0.9 ? 1 : 0;
      ASSERT_TRUE(on_near == 0 || on_near == 3) << s.name;
      (on_near == 3 ? near : far) += 1;
    }
    EXPECT_GT(near, 1000) << s.name;
    EXPECT_GT(far, 1000) << s.name;
  }
}

// A solid object's inside is never seen: drawn as a solid, a square turned away from the camera
// (the inside of a shell, seen through a hole) is not drawn and the square behind it, turned
// toward the camera, is; drawn with both sides, the nearer square hides the farther.
TEST(RangeScanTest, SolidHidesFacesTurnedAway) {
  const SensorModel s = SensorModel::StructuredLight();
  const Camera cam = Front(s);
  Mesh scene = Square({0, 0, 1.0}, {1, 0, 0}, {0, 1, 0}, 0.3);    // normal +z: turned away
  Append(scene, Square({0, 0, 1.2}, {0, 1, 0}, {1, 0, 0}, 0.6));  // normal -z: toward the camera
  for (bool solid : {true, false}) {
    const DepthImage image = RenderDepth(scene, cam, solid);
    const size_t centre = static_cast<size_t>(s.height / 2) * s.width + s.width / 2;
    EXPECT_NEAR(image.depth[centre], solid ? 1.2 : 1.0, 1e-9) << "solid " << solid;
    int64_t near = 0;
    for (double z : image.depth) near += z > 0.0 && z < 1.1 ? 1 : 0;
    if (solid) {
      EXPECT_EQ(near, 0);
    } else {
      EXPECT_GT(near, 10000);
    }
  }
}

}  // namespace
}  // namespace meshsmooth::bench
