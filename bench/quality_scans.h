// The quality benchmark's scan cases: clean meshes as depth cameras scan them (bench/range_scan.h:
// a time-of-flight frame, a structured-light frame, and frames fused in a voxel volume), measured
// against the clean surface they were scanned from, and the real Kinect-Fusion cone of
// ../shared/data/real measured face for face against its reference. docs/quality-method.md,
// "Scans", says how the cases are made and read.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "bench/quality_runs.h"
#include "core/measure/evaluation.h"
#include "core/mesh.h"
#include "core/topology.h"

namespace meshsmooth::bench {

enum class ScanKind { kTimeOfFlight, kStructuredLight, kFused };

// The clean meshes the scan cases scan: a CAD part with creases, an organic scan, a mesh with fine
// detail, a large smooth shape (LoadSubject's names).
inline const std::vector<std::string> kScanMeshes = {"fandisk", "stanford-bunny", "nefertiti", "sphere"};

struct ScanOptions {
  std::vector<std::string> meshes = kScanMeshes;
  std::vector<ScanKind> kinds = {ScanKind::kTimeOfFlight, ScanKind::kStructuredLight, ScanKind::kFused};
  int seeds = 2;         // scans per mesh and kind, each from its own pose
  bool held_out = true;  // the held-out seeds and poses; false: the tuning ones
  bool real = true;      // the real cone, when ../shared/data/real holds it
};

// The scan kinds named in `s` ("tof,sl,fused"); InvalidArgument on an unknown name.
absl::StatusOr<std::vector<ScanKind>> ParseScanKinds(const std::string& s);

// `result` (a mesh of its own connectivity, `topology` its topology) against the clean surface of
// `clean`, distances over `h`: the distance of each vertex a usable face touches to the surface,
// each face's normal against the normal of the clean triangle nearest to its centroid (flipped:
// pointing against it), the regularity of the result; volume and crease error are NaN.
absl::StatusOr<Quality> EvaluateOnSurface(const GroundTruth& clean, const Mesh& result, const Topology& topology,
                                          double h);

// `clean` scaled to the scanned object's size (metres, centred on the origin), its faces turned
// outward where they enclose a negative volume.
Mesh ToObjectScale(Mesh clean);

// Scan number `index` (0, 1, ...) of `object` (at object scale) of kind `kind`, from the held-out
// or the tuning seeds and poses.
Mesh MakeScan(const Mesh& object, ScanKind kind, bool held_out, int index);

// Runs `jobs` on every scan case of `options` (the clean meshes from `meshes`, the real scans
// from `real`) and appends the section: a summary over the cases, then every row case by case.
void ScanSection(std::string& out, const ScanOptions& options, const std::vector<Job>& jobs,
                 const std::filesystem::path& meshes, const std::filesystem::path& real);

}  // namespace meshsmooth::bench
