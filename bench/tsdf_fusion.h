// Depth frames fused as KinectFusion and other TSDF pipelines fuse them: a voxel grid of
// truncated signed distances averaged over the frames (Curless & Levoy 1996), extracted by the
// project's marching tetrahedra (core/shapes/marching_tetrahedra.h), so every vertex lies on a
// grid edge; only the surface the frames saw is kept (an open mesh where they saw part of it).
#pragma once

#include <cstdint>
#include <vector>

#include "bench/range_scan.h"
#include "core/mesh.h"
#include "core/vec3.h"

namespace meshsmooth::bench {

// A measured frame and the pose the fusion believes it was taken from.
struct PosedFrame {
  DepthImage depth;
  Camera camera;
};

// Fuses `frames` on the grid lo + voxel (i, j, k) over [lo, hi]: at each node the mean over the
// frames that see it of (measured depth - node depth) / truncation, clamped to [-1, 1], skipping
// a frame where the node lies more than `truncation` behind the measured surface. The zero set is
// extracted and the triangles of cells with a node no frame saw are dropped.
Mesh FuseFrames(const std::vector<PosedFrame>& frames, const Vec3& lo, const Vec3& hi, double voxel, double truncation);

// The camera `camera` moved by a pose error: turned about `centre` by the rotation vector
// `rotation` (axis times angle in radians), then shifted by `shift`.
Camera PerturbPose(const Camera& camera, const Vec3& centre, const Vec3& rotation, const Vec3& shift);

// A fused scan as a hand-held depth camera makes one: a frame of `sensor` from each of
// `cameras`, fused from poses off by a pose error shared by `segments` runs of consecutive
// frames (drift leaves a loop's frames registered run by run: low-frequency bumps where they
// disagree), over the bounding box of `clean` grown by three truncations. The pose error's size
// is calibrated against a real Kinect-Fusion scan (tests/bench/scan_calibration_test.cc): with it
// the simulated scan of the real scan's cone has the real one's normal error, spread of offsets
// and their correlation length along the surface, each within 1.5 times.
struct FusedScanOptions {
  int segments = 6;
  double pose_error_deg = 0.6;       // standard deviation of a run's turn about the object's centre
  double pose_error_shift = 0.0025;  // and of its shift per axis (metres)
  double voxel = 0.8 / 256;          // metres: KinectFusion's 256^3 over 0.8 m
  double truncation = 4 * 0.8 / 256;
  bool solid = true;  // `clean` is the outside of a solid object (RenderDepth's `solid`)
};
Mesh SimulateFusedScan(const Mesh& clean, const std::vector<Camera>& cameras, const SensorModel& sensor,
                       const FusedScanOptions& options, uint64_t seed);

}  // namespace meshsmooth::bench
