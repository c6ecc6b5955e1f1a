#include "bench/range_scan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/render/raster.h"
#include "core/shapes/random.h"

namespace meshsmooth::bench {
namespace {

using shapes_internal::SplitMix64;

constexpr double kNearestDepth = 1e-3;  // faces with a corner nearer than this are not drawn

// theta^2 / (pi/2 - theta)^2 and theta / (pi/2 - theta), the incidence terms of the noise
// models, finite up to grazing.
double Grazing(double theta) { return theta / std::max(std::numbers::pi / 2 - theta, 1e-3); }

// A field of unit-variance Gaussian noise over the image, correlated by a Gaussian window of
// standard deviation `correlation_px / 2` (autocorrelation exp(-d^2 / correlation_px^2)):
// white noise on a padded grid, blurred along rows and columns, scaled back to unit variance.
std::vector<double> CorrelatedNoise(int width, int height, double correlation_px, SplitMix64& rng) {
  const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);
  std::vector<double> out(n);
  if (!(correlation_px > 0.0)) {
    for (double& v : out) v = rng.NextGaussian();
    return out;
  }
  const double s = correlation_px / 2.0;
  const int r = static_cast<int>(std::ceil(3.0 * s));
  std::vector<double> kernel(2 * r + 1);
  double sum = 0.0, sum2 = 0.0;
  for (int i = -r; i <= r; ++i) sum += kernel[i + r] = std::exp(-0.5 * i * i / (s * s));
  for (double& k : kernel) {
    k /= sum;
    sum2 += k * k;
  }
  const double scale = 1.0 / sum2;  // the 2-D window's squares sum to sum2^2
  const int pw = width + 2 * r, ph = height + 2 * r;
  std::vector<double> white(static_cast<size_t>(pw) * ph), rows(static_cast<size_t>(width) * ph);
  for (double& v : white) v = rng.NextGaussian();
  for (int y = 0; y < ph; ++y) {
    for (int x = 0; x < width; ++x) {
      double acc = 0.0;
      for (int k = 0; k <= 2 * r; ++k) acc += kernel[k] * white[static_cast<size_t>(y) * pw + x + k];
      rows[static_cast<size_t>(y) * width + x] = acc;
    }
  }
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double acc = 0.0;
      for (int k = 0; k <= 2 * r; ++k) acc += kernel[k] * rows[static_cast<size_t>(y + k) * width + x];
      out[static_cast<size_t>(y) * width + x] = acc * scale;
    }
  }
  return out;
}

// Depth along the ray `ray` (depth component 1) to the plane of face f, or NaN when the ray is
// parallel to it.
double PlaneDepth(const Mesh& mesh, int32_t f, const Camera& camera, const Vec3& ray) {
  const Triangle& t = mesh.triangles[f];
  const Vec3& a = mesh.positions[t[0]];
  const Vec3 n = Cross(mesh.positions[t[1]] - a, mesh.positions[t[2]] - a);
  const double den = Dot(n, ray);
  return den != 0.0 ? Dot(n, a - camera.eye) / den : std::nan("");
}

}  // namespace

Camera Camera::LookAt(const Vec3& eye, const Vec3& target, const Vec3& up, int width, int height, double focal_px) {
  Camera c;
  c.eye = eye;
  c.forward = Normalized(target - eye);
  c.right = Normalized(Cross(c.forward, up));
  c.down = Cross(c.forward, c.right);
  c.width = width;
  c.height = height;
  c.focal_px = focal_px;
  return c;
}

Vec3 Camera::RayAt(double u, double v) const {
  return forward + ((u - 0.5 * width) / focal_px) * right + ((v - 0.5 * height) / focal_px) * down;
}

Vec3 Camera::Ray(int64_t index) const {
  return RayAt(static_cast<double>(index % width) + 0.5, static_cast<double>(index / width) + 0.5);
}

double SensorModel::SigmaZ(double z, double theta) const {
  const double g = Grazing(theta);
  return sigma_a + sigma_b * (z - sigma_z0) * (z - sigma_z0) + sigma_angle * std::pow(z, angle_power) * g * g;
}

double SensorModel::SigmaLateral(double theta) const { return lateral_a + lateral_b * Grazing(theta); }

double SensorModel::Quantize(double z) const {
  if (coding == DepthCoding::kMillimetres) {
    return depth_step > 0.0 ? std::round(z / depth_step) * depth_step : z;
  }
  if (!(disparity_step_px > 0.0)) return z;
  const double fb = focal_px * baseline;
  return fb / (std::round(fb / z / disparity_step_px) * disparity_step_px);
}

double SensorModel::JumpThreshold(double z) const { return jump_slope * z / focal_px + jump_sigmas * SigmaZ(z, 0.0); }

SensorModel SensorModel::StructuredLight() {
  SensorModel s;
  s.name = "structured light (Kinect v1)";
  s.width = 640;
  s.height = 480;
  s.focal_px = 580.0;
  // Nguyen, Izadi & Lovell 2012: 0.0012 + 0.0019 (z - 0.4)^2 m, plus 0.0001 / sqrt(z) theta^2 /
  // (pi/2 - theta)^2 m toward grazing; lateral 0.8 + 0.035 theta / (pi/2 - theta) px.
  s.sigma_a = 0.0012;
  s.sigma_b = 0.0019;
  s.sigma_z0 = 0.4;
  s.sigma_angle = 0.0001;
  s.angle_power = -0.5;
  s.lateral_a = 0.8;
  s.lateral_b = 0.035;
  // The disparity is matched over a 9 x 9 window: a box of 9 pixels is a Gaussian of standard
  // deviation 9 / sqrt(12) = 2.6 px, whose autocorrelation falls to 1/e at 5.2 px.
  s.correlation_px = 5.2;
  // Disparity in 1/8 pixel over a 7.5 cm baseline, as the Kinect v1 is commonly described (its
  // depth from disparity: Khoshelham & Elberink 2012), so a depth step of z^2 / (8 f b) =
  // 2.9e-3 z^2 m.
  s.coding = DepthCoding::kDisparity;
  s.baseline = 0.075;
  s.disparity_step_px = 0.125;
  s.max_incidence_deg = 75.0;
  s.min_depth = 0.5;
  s.max_depth = 4.0;
  return s;
}

SensorModel SensorModel::TimeOfFlight() {
  SensorModel s;
  s.name = "time of flight (Kinect v2)";
  s.width = 512;
  s.height = 424;
  s.focal_px = 365.0;
  // Fankhauser et al. 2015 (axial, indoors): 1.5 - 0.5 z + 0.3 z^2 mm (= 1.29 + 0.3 (z - 0.83)^2),
  // plus 0.1 z^1.5 theta^2 / (pi/2 - theta)^2 mm toward grazing. The lateral half pixel is ours,
  // not the paper's figure.
  s.sigma_a = 0.00129;
  s.sigma_b = 0.0003;
  s.sigma_z0 = 0.833;
  s.sigma_angle = 0.0001;
  s.angle_power = 1.5;
  s.lateral_a = 0.5;
  s.lateral_b = 0.0;
  // Each pixel demodulates its own light; the sensor's own smoothing spreads it over about a pixel.
  s.correlation_px = 1.0;
  s.coding = DepthCoding::kMillimetres;  // the frame holds whole millimetres
  s.depth_step = 0.001;
  s.max_incidence_deg = 75.0;
  s.min_depth = 0.5;
  s.max_depth = 4.5;
  return s;
}

DepthImage RenderDepth(const Mesh& mesh, const Camera& camera, bool solid) {
  DepthImage img;
  img.width = camera.width;
  img.height = camera.height;
  const size_t n = static_cast<size_t>(img.width) * static_cast<size_t>(img.height);
  img.depth.assign(n, 0.0);
  img.face.assign(n, -1);
  img.incidence.assign(n, 0.0);
  // The raster keeps the face of largest 1/z per pixel: 1/z is linear on the screen under a
  // perspective projection, so the nearest face wins exactly where z would be interpolated wrongly.
  std::vector<double> inv_depth(n, 0.0);
  const int32_t nv = mesh.num_vertices();
  std::vector<raster::ScreenPoint> screen(nv);
  std::vector<double> inv(nv);
  for (int32_t i = 0; i < nv; ++i) {
    const Vec3 d = mesh.positions[i] - camera.eye;
    const double z = Dot(d, camera.forward);
    inv[i] = z > kNearestDepth ? 1.0 / z : 0.0;
    if (inv[i] == 0.0) continue;
    screen[i] = {raster::ToFixed(0.5 * camera.width + camera.focal_px * Dot(d, camera.right) * inv[i]),
                 raster::ToFixed(0.5 * camera.height + camera.focal_px * Dot(d, camera.down) * inv[i])};
  }
  for (int32_t f = 0; f < mesh.num_triangles(); ++f) {
    const Triangle& t = mesh.triangles[f];
    if (!IsUsableTriangle(t, nv) || inv[t[0]] == 0.0 || inv[t[1]] == 0.0 || inv[t[2]] == 0.0) continue;
    if (solid) {
      const Vec3& a = mesh.positions[t[0]];
      if (Dot(Cross(mesh.positions[t[1]] - a, mesh.positions[t[2]] - a), a - camera.eye) >= 0.0) continue;
    }
    raster::ForEachCoveredPixel(camera.width, camera.height, screen[t[0]], screen[t[1]], screen[t[2]],
                                [&](size_t index, double l0, double l1, double l2) {
                                  const double w = l0 * inv[t[0]] + l1 * inv[t[1]] + l2 * inv[t[2]];
                                  if (w > inv_depth[index]) {
                                    inv_depth[index] = w;
                                    img.face[index] = f;
                                  }
                                });
  }
  for (size_t i = 0; i < n; ++i) {
    const int32_t f = img.face[i];
    if (f < 0) continue;
    const Vec3 ray = camera.Ray(static_cast<int64_t>(i));
    const double z = PlaneDepth(mesh, f, camera, ray);
    const Triangle& t = mesh.triangles[f];
    const Vec3 normal = Cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
    const double len = Norm(normal) * Norm(ray);
    if (!(z > kNearestDepth) || !(len > 0.0)) {
      img.face[i] = -1;
      continue;
    }
    img.depth[i] = z;
    img.incidence[i] = std::acos(std::min(1.0, std::abs(Dot(normal, ray)) / len));
  }
  return img;
}

DepthImage MeasureDepth(const DepthImage& clean, const Mesh& mesh, const Camera& camera, const SensorModel& sensor,
                        uint64_t seed) {
  const int w = clean.width, h = clean.height;
  SplitMix64 rng(seed);
  const std::vector<double> axial = CorrelatedNoise(w, h, sensor.correlation_px, rng);
  DepthImage out = clean;
  const double max_incidence = sensor.max_incidence_deg * std::numbers::pi / 180.0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      // Two draws per pixel whether it is kept or not: a pixel's noise does not depend on others.
      const double ju = rng.NextGaussian(), jv = rng.NextGaussian();
      const double z = clean.depth[i];
      if (clean.face[i] < 0) continue;
      bool keep = clean.incidence[i] <= max_incidence && z >= sensor.min_depth && z <= sensor.max_depth;
      // A pixel next to a depth jump (or the silhouette) is a flying pixel: dropped.
      for (const auto& [dx, dy] : {std::pair{1, 0}, std::pair{-1, 0}, std::pair{0, 1}, std::pair{0, -1}}) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
        const size_t j = static_cast<size_t>(ny) * w + nx;
        if (clean.face[j] < 0 || std::abs(clean.depth[j] - z) > sensor.JumpThreshold(z)) keep = false;
      }
      if (!keep) {
        out.depth[i] = 0.0;
        out.face[i] = -1;
        continue;
      }
      // Lateral jitter: the depth comes from a ray off the pixel's centre, on the face seen there.
      const double theta = clean.incidence[i];
      const double sl = sensor.SigmaLateral(theta);
      const double u = x + 0.5 + sl * ju, v = y + 0.5 + sl * jv;
      const int qx = std::clamp(static_cast<int>(std::floor(u)), 0, w - 1);
      const int qy = std::clamp(static_cast<int>(std::floor(v)), 0, h - 1);
      const int32_t qf = clean.face[static_cast<size_t>(qy) * w + qx];
      double zj = qf >= 0 ? PlaneDepth(mesh, qf, camera, camera.RayAt(u, v)) : z;
      if (!(std::abs(zj - z) <= sensor.JumpThreshold(z))) zj = z;  // a ray past the face's plane's reach
      out.depth[i] = sensor.Quantize(zj + sensor.SigmaZ(z, theta) * axial[i]);
    }
  }
  return out;
}

RangeMesh Triangulate(const DepthImage& image, const Camera& camera, const SensorModel& sensor) {
  const int w = image.width, h = image.height;
  RangeMesh out;
  std::vector<int32_t> vertex(image.depth.size(), -1);
  auto vertex_of = [&](size_t i) {
    if (vertex[i] < 0) {
      vertex[i] = out.mesh.num_vertices();
      out.mesh.positions.push_back(camera.eye + image.depth[i] * camera.Ray(static_cast<int64_t>(i)));
      out.pixel.push_back(static_cast<int64_t>(i));
    }
    return vertex[i];
  };
  auto joined = [&](size_t a, size_t b) {
    const double za = image.depth[a], zb = image.depth[b];
    return std::abs(za - zb) <= sensor.JumpThreshold(std::min(za, zb));
  };
  auto add = [&](size_t a, size_t b, size_t c) {
    if (image.depth[a] > 0.0 && image.depth[b] > 0.0 && image.depth[c] > 0.0 && joined(a, b) && joined(b, c) &&
        joined(c, a)) {
      out.mesh.triangles.push_back({vertex_of(a), vertex_of(b), vertex_of(c)});
    }
  };
  for (int y = 0; y + 1 < h; ++y) {
    for (int x = 0; x + 1 < w; ++x) {
      const size_t p00 = static_cast<size_t>(y) * w + x, p10 = p00 + 1, p01 = p00 + w, p11 = p01 + 1;
      // (right, down) make a face whose normal points back at the camera.
      add(p00, p01, p10);
      add(p10, p01, p11);
    }
  }
  return out;
}

RangeMesh SimulateFrame(const Mesh& mesh, const Camera& camera, const SensorModel& sensor, uint64_t seed, bool solid) {
  return Triangulate(MeasureDepth(RenderDepth(mesh, camera, solid), mesh, camera, sensor, seed), camera, sensor);
}

}  // namespace meshsmooth::bench
