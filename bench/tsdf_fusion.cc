#include "bench/tsdf_fusion.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/shapes/marching_tetrahedra.h"
#include "core/shapes/random.h"

namespace meshsmooth::bench {
namespace {

// Rodrigues' rotation of v about the unit axis k by angle a.
Vec3 Rotate(const Vec3& v, const Vec3& k, double a) {
  return std::cos(a) * v + std::sin(a) * Cross(k, v) + (1.0 - std::cos(a)) * Dot(k, v) * k;
}

// The depth image at image point (u, v): bilinear between the four nearest pixel centres when
// they all hold depths within 2% of each other, else the nearest pixel's (0: none).
double DepthAt(const DepthImage& image, double u, double v) {
  const int x = static_cast<int>(std::floor(u - 0.5)), y = static_cast<int>(std::floor(v - 0.5));
  const int nx = static_cast<int>(std::floor(u)), ny = static_cast<int>(std::floor(v));
  if (nx < 0 || ny < 0 || nx >= image.width || ny >= image.height) return 0.0;
  const double nearest = image.depth[static_cast<size_t>(ny) * image.width + nx];
  if (x < 0 || y < 0 || x + 1 >= image.width || y + 1 >= image.height) return nearest;
  const size_t i = static_cast<size_t>(y) * image.width + x;
  const double d00 = image.depth[i], d10 = image.depth[i + 1], d01 = image.depth[i + image.width],
               d11 = image.depth[i + image.width + 1];
  const double lo = std::min({d00, d10, d01, d11}), hi = std::max({d00, d10, d01, d11});
  if (!(lo > 0.0) || hi - lo > 0.02 * lo) return nearest;
  const double a = u - 0.5 - x, b = v - 0.5 - y;
  return (1 - b) * ((1 - a) * d00 + a * d10) + b * ((1 - a) * d01 + a * d11);
}

}  // namespace

Camera PerturbPose(const Camera& camera, const Vec3& centre, const Vec3& rotation, const Vec3& shift) {
  const double angle = Norm(rotation);
  if (!(angle > 0.0)) {
    Camera c = camera;
    c.eye = camera.eye + shift;
    return c;
  }
  const Vec3 axis = rotation * (1.0 / angle);
  Camera c = camera;
  c.eye = centre + Rotate(camera.eye - centre, axis, angle) + shift;
  c.right = Rotate(camera.right, axis, angle);
  c.down = Rotate(camera.down, axis, angle);
  c.forward = Rotate(camera.forward, axis, angle);
  return c;
}

Mesh FuseFrames(const std::vector<PosedFrame>& frames, const Vec3& lo, const Vec3& hi, double voxel,
                double truncation) {
  const int nx = static_cast<int>(std::ceil((hi.x - lo.x) / voxel)) + 1;
  const int ny = static_cast<int>(std::ceil((hi.y - lo.y) / voxel)) + 1;
  const int nz = static_cast<int>(std::ceil((hi.z - lo.z) / voxel)) + 1;
  const size_t n = static_cast<size_t>(nx) * ny * nz;
  std::vector<float> sdf(n, 0.0f);
  std::vector<uint16_t> weight(n, 0);
  std::vector<uint8_t> behind(n, 0);  // seen only far behind a surface: inside
  auto node = [&](int i, int j, int k) { return (static_cast<size_t>(k) * ny + j) * nx + i; };
#pragma omp parallel for schedule(dynamic, 4)
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const Vec3 p = lo + Vec3{i * voxel, j * voxel, k * voxel};
        double sum = 0.0;
        int count = 0;
        bool hidden = false;
        for (const PosedFrame& f : frames) {
          const Camera& c = f.camera;
          const Vec3 d = p - c.eye;
          const double z = Dot(d, c.forward);
          if (!(z > 0.0)) continue;
          const double measured = DepthAt(f.depth, 0.5 * c.width + c.focal_px * Dot(d, c.right) / z,
                                          0.5 * c.height + c.focal_px * Dot(d, c.down) / z);
          if (!(measured > 0.0)) continue;
          const double s = measured - z;
          if (s < -truncation) {
            hidden = true;
            continue;
          }
          sum += std::min(1.0, s / truncation);
          ++count;
        }
        const size_t at = node(i, j, k);
        if (count > 0) {
          sdf[at] = static_cast<float>(sum / count);
          weight[at] = static_cast<uint16_t>(std::min(count, 65535));
        } else {
          behind[at] = hidden ? 1 : 0;
        }
      }
    }
  }
  auto index_of = [&](const Vec3& p, int& i, int& j, int& k) {
    i = std::clamp(static_cast<int>(std::lround((p.x - lo.x) / voxel)), 0, nx - 1);
    j = std::clamp(static_cast<int>(std::lround((p.y - lo.y) / voxel)), 0, ny - 1);
    k = std::clamp(static_cast<int>(std::lround((p.z - lo.z) / voxel)), 0, nz - 1);
  };
  // The extractor samples exactly the grid nodes (same lo and step).
  const Mesh all = MarchingTetrahedra(
      [&](const Vec3& p) {
        int i, j, k;
        index_of(p, i, j, k);
        const size_t at = node(i, j, k);
        if (weight[at] > 0) return static_cast<double>(sdf[at]);
        return behind[at] ? -1.0 : 1.0;
      },
      lo, lo + Vec3{(nx - 1) * voxel, (ny - 1) * voxel, (nz - 1) * voxel}, voxel);
  // Keep the triangles whose cell (the grid cube holding the centroid) was seen at every corner.
  Mesh out;
  std::vector<int32_t> remap(all.positions.size(), -1);
  for (const Triangle& t : all.triangles) {
    const Vec3 c = (all.positions[t[0]] + all.positions[t[1]] + all.positions[t[2]]) * (1.0 / 3.0);
    const int ci = std::clamp(static_cast<int>(std::floor((c.x - lo.x) / voxel)), 0, nx - 2);
    const int cj = std::clamp(static_cast<int>(std::floor((c.y - lo.y) / voxel)), 0, ny - 2);
    const int ck = std::clamp(static_cast<int>(std::floor((c.z - lo.z) / voxel)), 0, nz - 2);
    bool seen = true;
    for (int corner = 0; corner < 8 && seen; ++corner) {
      seen = weight[node(ci + (corner & 1), cj + ((corner >> 1) & 1), ck + ((corner >> 2) & 1))] > 0;
    }
    if (!seen) continue;
    Triangle kept;
    for (int a = 0; a < 3; ++a) {
      if (remap[t[a]] < 0) {
        remap[t[a]] = out.num_vertices();
        out.positions.push_back(all.positions[t[a]]);
      }
      kept[a] = remap[t[a]];
    }
    out.triangles.push_back(kept);
  }
  return out;
}

Mesh SimulateFusedScan(const Mesh& clean, const std::vector<Camera>& cameras, const SensorModel& sensor,
                       const FusedScanOptions& options, uint64_t seed) {
  BoundingBox box;
  for (const Vec3& p : clean.positions) box.Add(p);
  const Vec3 centre = box.lo + 0.5 * (box.hi - box.lo);
  // The drift: a rotation vector and a shift at segments + 1 evenly spaced frames.
  shapes_internal::SplitMix64 rng(seed * 7919 + 1);
  const double rot = options.pose_error_deg * std::numbers::pi / 180.0;
  std::vector<Vec3> rotations, shifts;
  for (int k = 0; k <= options.segments; ++k) {
    rotations.push_back(rot * Vec3{rng.NextGaussian(), rng.NextGaussian(), rng.NextGaussian()});
    shifts.push_back(options.pose_error_shift * Vec3{rng.NextGaussian(), rng.NextGaussian(), rng.NextGaussian()});
  }
  std::vector<PosedFrame> frames;
  const auto n = static_cast<int>(cameras.size());
  for (int f = 0; f < n; ++f) {
    const Camera& truth = cameras[f];
    DepthImage measured = MeasureDepth(RenderDepth(clean, truth, options.solid), clean, truth, sensor, seed * 1000 + f);
    const double x = n > 1 ? static_cast<double>(f) * options.segments / (n - 1) : 0.0;
    const int k = std::min(static_cast<int>(x), options.segments - 1);
    const double t = x - k;
    frames.push_back({std::move(measured), PerturbPose(truth, centre, (1 - t) * rotations[k] + t * rotations[k + 1],
                                                       (1 - t) * shifts[k] + t * shifts[k + 1])});
  }
  const double m = 3 * options.truncation;
  return FuseFrames(frames, box.lo - Vec3{m, m, m}, box.hi + Vec3{m, m, m}, options.voxel, options.truncation);
}

}  // namespace meshsmooth::bench
