// A range-scan simulator for the quality benchmark: what a depth camera makes of a clean mesh.
// The mesh's depth is rendered from a pinhole camera (core/render/raster.h's coverage), then
// the sensor's error is added in the sensor's own terms -- axial noise along each pixel's ray
// with a deviation that grows with depth and incidence, correlated over a window of pixels,
// lateral jitter, and the depth quantization of the sensor's output (whole millimetres for
// time of flight, disparity steps for structured light) -- pixels seen at grazing angles or
// next to a depth jump are dropped, and the pixel grid is triangulated into an open mesh with no
// triangle across a depth jump, as scanners' own software does. docs/quality-method.md gives
// the sensor figures and their sources. Positions are in metres; seeded: the same seed gives
// the same bytes on every machine.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/vec3.h"

namespace meshsmooth::bench {

// A pinhole camera. Camera frame: x to the right, y down, z forward (depth); pixel (x, y)'s
// centre is at (x + 1/2, y + 1/2), the principal point at the image centre.
struct Camera {
  Vec3 eye, right, down, forward;  // orthonormal
  int width = 0, height = 0;
  double focal_px = 0.0;

  // Looking from `eye` at `target`, image up toward `up` (not parallel to the view).
  static Camera LookAt(const Vec3& eye, const Vec3& target, const Vec3& up, int width, int height, double focal_px);

  // The world direction through the centre of pixel `index` (y * width + x), scaled so that its
  // depth component is 1: the pixel's point at depth z is eye + z * Ray(index).
  Vec3 Ray(int64_t index) const;
  // The same through the image point (u, v) in pixels.
  Vec3 RayAt(double u, double v) const;
  // The depth (camera z) of `p`.
  double Depth(const Vec3& p) const { return Dot(p - eye, forward); }
};

// How a sensor codes depth in its output.
enum class DepthCoding {
  kMillimetres,  // time of flight: whole multiples of `depth_step` (Kinect v2: 1 mm)
  kDisparity,    // structured light: disparity f b / z in steps of `disparity_step_px`
};

struct SensorModel {
  std::string name;
  int width = 0, height = 0;
  double focal_px = 0.0;
  // Axial deviation in metres at depth z and incidence theta (radians from the surface normal):
  // sigma_a + sigma_b (z - sigma_z0)^2 + sigma_angle z^angle_power theta^2 / (pi/2 - theta)^2.
  double sigma_a = 0.0, sigma_b = 0.0, sigma_z0 = 0.0, sigma_angle = 0.0, angle_power = 0.0;
  // Lateral jitter, standard deviation in pixels: lateral_a + lateral_b theta / (pi/2 - theta).
  double lateral_a = 0.0, lateral_b = 0.0;
  // The axial noise's correlation length in pixels: the lag at which its autocorrelation falls
  // to 1/e (a Gaussian window of standard deviation correlation_px / 2); 0: independent.
  double correlation_px = 0.0;
  DepthCoding coding = DepthCoding::kMillimetres;
  double depth_step = 0.0;                         // kMillimetres, metres; 0: no quantization
  double baseline = 0.0, disparity_step_px = 0.0;  // kDisparity; a step of 0: no quantization
  double max_incidence_deg = 90.0;                 // pixels seen more obliquely are dropped
  double min_depth = 0.0, max_depth = 1e300;       // pixels outside are dropped
  // Two pixels next to each other are across a depth jump when their depths differ by more than
  // jump_slope z / focal_px (a surface that steep to the ray) plus jump_sigmas sigma_z(z, 0).
  double jump_slope = 8.0, jump_sigmas = 6.0;

  // The axial deviation (metres) at depth z and incidence theta.
  double SigmaZ(double z, double theta) const;
  // The lateral deviation (pixels) at incidence theta.
  double SigmaLateral(double theta) const;
  // Depth z as the sensor's output codes it.
  double Quantize(double z) const;
  // The depth difference between neighbouring pixels at depth z above which they are across a jump.
  double JumpThreshold(double z) const;

  // Kinect v1 (structured light): the deviations of Nguyen, Izadi & Lovell 2012, depth from
  // disparity as in Khoshelham & Elberink 2012.
  static SensorModel StructuredLight();
  // Kinect v2 (time of flight): the axial deviation of Fankhauser et al. 2015.
  static SensorModel TimeOfFlight();
};

// A depth image: per pixel (y * width + x) the depth along the optical axis, 0 where the pixel
// holds nothing, and for a rendered image the face seen there and the incidence (radians).
struct DepthImage {
  int width = 0, height = 0;
  std::vector<double> depth;
  std::vector<int32_t> face;  // -1: nothing
  std::vector<double> incidence;
};

// The clean depth of `mesh`'s usable faces from `camera`: the nearest face along each pixel's ray
// (exact ray-plane depth of the face the raster found there). Faces with a corner behind or
// within 1 mm of the camera are skipped. `solid`: the mesh is the outside of a solid object,
// faces outward, so a face turned away from the camera is its inside and is not drawn: through
// an open mesh's holes (a scan's, or a reference that covers only the scanned side) the camera
// sees nothing rather than the inside of a shell, which no camera sees on a solid object.
DepthImage RenderDepth(const Mesh& mesh, const Camera& camera, bool solid = false);

// What `sensor` reports for the clean image `clean` of `mesh`: lateral jitter, correlated axial
// noise and quantization, with the grazing pixels, the pixels next to a depth jump and those
// out of range dropped (depth 0). `camera` must be the one `clean` was rendered with.
DepthImage MeasureDepth(const DepthImage& clean, const Mesh& mesh, const Camera& camera, const SensorModel& sensor,
                        uint64_t seed);

// An open mesh of a depth image: every pixel a vertex on its ray, two triangles per 2 x 2 block
// of pixels, each formed only when its three pixels hold depths and no two of them are across
// a depth jump (SensorModel::JumpThreshold); faces toward the camera. Pixels no triangle uses
// are left out; pixel[i] is vertex i's pixel.
struct RangeMesh {
  Mesh mesh;
  std::vector<int64_t> pixel;
};
RangeMesh Triangulate(const DepthImage& image, const Camera& camera, const SensorModel& sensor);

// One frame: RenderDepth (of a solid object when `solid`), MeasureDepth, Triangulate.
RangeMesh SimulateFrame(const Mesh& mesh, const Camera& camera, const SensorModel& sensor, uint64_t seed,
                        bool solid = false);

}  // namespace meshsmooth::bench
