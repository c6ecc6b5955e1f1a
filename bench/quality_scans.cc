#include "bench/quality_scans.h"

#include <omp.h>
#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "bench/bench_common.h"
#include "bench/quality_inputs.h"
#include "bench/quality_tables.h"
#include "bench/range_scan.h"
#include "bench/tsdf_fusion.h"
#include "core/io/mesh_io.h"
#include "core/measure/metrics.h"

namespace meshsmooth::bench {
namespace {

// Every scanned mesh is scaled to this bounding-box diagonal (metres), centred on the origin,
// and scanned from this distance: a hand-held object in a depth camera's near range.
constexpr double kObjectDiagonal = 0.3;
constexpr double kScanDistance = 0.75;
// Fused scans: kFusedFrames structured-light frames on a turn around the object
// (SimulateFusedScan's defaults: KinectFusion's voxel of 0.8 m / 256, drift in six runs).
constexpr int kFusedFrames = 48;

// The scan cases' oracle sweeps: a coarse series of counts (1-2-5 per decade) with a stop at the
// first count worse than the best, up to 1000 on the frames and 500 on the fused scans and the
// real cone, whose iteration costs five to ten times a frame's (docs/decisions.md, "The scan
// cases' oracle: a coarse sweep").
const Sweep kFrameSweep = {{1, 2, 5, 10, 20, 50, 100, 200, 500, 1000}, 1};
const Sweep kFusedSweep = {{1, 2, 5, 10, 20, 50, 100, 200, 500}, 1};

// Seeds and poses (azimuth, elevation in degrees about the object): tuning and held-out sets
// share nothing.
constexpr uint64_t kTuningSeed = 1, kHeldOutSeed = 1001;
constexpr std::pair<double, double> kTuningPoses[] = {{20, 15}, {200, 30}, {110, 10}};
constexpr std::pair<double, double> kHeldOutPoses[] = {{65, 25}, {250, 20}, {155, 35}};

const char* KindName(ScanKind k) {
  switch (k) {
    case ScanKind::kTimeOfFlight:
      return "time-of-flight frame";
    case ScanKind::kStructuredLight:
      return "structured-light frame";
    case ScanKind::kFused:
      return "fused scan";
  }
  return "";
}

Camera CameraAt(const SensorModel& s, double azimuth_deg, double elevation_deg) {
  const double az = azimuth_deg * std::numbers::pi / 180, el = elevation_deg * std::numbers::pi / 180;
  const Vec3 eye = kScanDistance * Vec3{std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)};
  return Camera::LookAt(eye, {0, 0, 0}, {0, 1, 0}, s.width, s.height, s.focal_px);
}

// One scan of `clean` (in metres, about the origin) of kind `kind` from pose `pose`.
Mesh Scan(const Mesh& clean, ScanKind kind, std::pair<double, double> pose, uint64_t seed) {
  if (kind != ScanKind::kFused) {
    const SensorModel s =
        kind == ScanKind::kTimeOfFlight ? SensorModel::TimeOfFlight() : SensorModel::StructuredLight();
    return SimulateFrame(clean, CameraAt(s, pose.first, pose.second), s, seed, /*solid=*/true).mesh;
  }
  // Structured-light frames (KinectFusion's sensor) on a turn around the object from the pose,
  // the elevation rising and falling by 20 degrees.
  const SensorModel s = SensorModel::StructuredLight();
  std::vector<Camera> cameras;
  for (int f = 0; f < kFusedFrames; ++f) {
    const double turn = static_cast<double>(f) / kFusedFrames;
    cameras.push_back(
        CameraAt(s, pose.first + 360.0 * turn, pose.second + 20.0 * std::sin(4 * std::numbers::pi * turn)));
  }
  return SimulateFusedScan(clean, cameras, s, FusedScanOptions(), seed);
}

// A scan as an input: the mesh, its topology and h, measured against the clean surface.
struct ScanInput {
  Mesh mesh;
  Topology topology;
  double h = 0.0;
};

std::vector<Input> InputsOf(const GroundTruth& clean, const std::vector<std::unique_ptr<ScanInput>>& scans) {
  std::vector<Input> inputs;
  for (const auto& s : scans) {
    const ScanInput* in = s.get();
    inputs.push_back({&in->mesh, &in->topology, [&clean, in](const Mesh& result) {
                        return EvaluateOnSurface(clean, result, in->topology, in->h);
                      }});
  }
  return inputs;
}

// The targets a default job is held to on a scan: a normal error below the authors' BNF and
// GNF rows' and below half the input's, an RMS distance below the input's.
std::string MissedScanTargets(const Quality& noisy, const Quality& d, double bnf, double gnf) {
  std::vector<std::string> missed;
  if (!(d.normal_error_deg < bnf)) missed.push_back("normal < BNF");
  if (!(d.normal_error_deg < gnf)) missed.push_back("normal < GNF");
  if (!(d.normal_error_deg <= 0.5 * noisy.normal_error_deg)) missed.push_back("normal ≤ 0.5×");
  if (!(d.rms_distance < noisy.rms_distance)) missed.push_back("RMS < input");
  return missed.empty() ? "none" : absl::StrJoin(missed, ", ");
}

std::string F(double v, int digits) { return std::isnan(v) ? "—" : absl::StrFormat("%.*f", digits, v); }

// One row of the scan summary: `name`, the input, the default job, the anchors and oracle rows
// (swept over `sweep`: a best count at its last count says so, the flow may do better beyond).
void SummaryRow(std::string& out, const std::string& name, const MeshCase& mc, const Sweep& sweep) {
  const Quality noisy = MeanQuality(mc.noisy), d = MeanQuality(mc.rows[0]);
  auto theta = [&](const std::string& label) {
    const Row* r = FindRow(mc, label);
    return r != nullptr && AllOk(*r) ? MeanQuality(*r).normal_error_deg : std::nan("");
  };
  auto oracle = [&](const std::string& label) {
    const Row* r = FindRow(mc, label);
    if (r == nullptr || !AllOk(*r)) return std::string("—");
    return absl::StrFormat("%.2f @ %d%s", MeanQuality(*r).normal_error_deg, r->iterations,
                           r->iterations == sweep.counts.back() ? " (the sweep's last)" : "");
  };
  double iterations = 0.0, noise = 0.0;
  for (const Run& r : mc.rows[0].runs) {
    iterations += r.iterations;
    noise += r.noise_h;
  }
  const double k = mc.rows[0].runs.empty() ? 0.0 : 1.0 / mc.rows[0].runs.size();
  const std::string stop = mc.rows[0].runs.empty() ? "—" : mc.rows[0].runs[0].stop;
  const double bnf = theta(kBnfLabel), gnf = theta(kGnfLabel);
  absl::StrAppendFormat(
      &out, "| %s | %d | %s | %s | %s (%.2f×) | %s (%.2f×) | %.0f, %s (%.3f) | %lld | %s | %s | %s | %s | %s |\n", name,
      mc.noisy.runs.empty() ? 0 : static_cast<int>(mc.noisy.runs.size()), F(noisy.rms_distance, 3),
      F(noisy.normal_error_deg, 2), F(d.rms_distance, 3), d.rms_distance / noisy.rms_distance, F(d.normal_error_deg, 2),
      d.normal_error_deg / noisy.normal_error_deg, iterations * k, stop, noise * k,
      static_cast<long long>(d.flipped_faces), F(bnf, 2), F(gnf, 2), oracle("bilateral_normal"),
      oracle("guided_normal"), MissedScanTargets(noisy, d, bnf, gnf));
}

constexpr char kSummaryHeader[] =
    "| case | seeds | noisy: RMS dist (h) | normal err (°) | default: RMS dist (h, × noisy) | normal err (°, × "
    "noisy) | default: iterations, stop (noise estimate, h) | flipped | BNF, authors' defaults: normal err (°) | "
    "GNF, authors' defaults | bilateral_normal oracle: normal err (°) @ iterations | guided_normal oracle | targets "
    "missed |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";

// Decompresses `xz` into `dir` (xz -dc) and reads it.
absl::StatusOr<Mesh> ReadXz(const std::filesystem::path& xz, const std::filesystem::path& dir) {
  const std::filesystem::path out = dir / xz.stem();
  const std::string cmd = absl::StrCat("xz -dc '", xz.string(), "' > '", out.string(), "'");
  if (std::system(cmd.c_str()) != 0) return absl::InternalError(absl::StrCat("failed: ", cmd));
  return ReadMesh(out.string());
}

}  // namespace

Mesh ToObjectScale(Mesh mesh) {
  BoundingBox box;
  for (const Vec3& p : mesh.positions) box.Add(p);
  const Vec3 centre = box.lo + 0.5 * (box.hi - box.lo);
  const double k = kObjectDiagonal / box.diagonal();
  for (Vec3& p : mesh.positions) p = (p - centre) * k;
  // Faces outward, as a scan's face its camera: the Stanford bunny's face inward.
  if (ComputeMetrics(mesh, BuildTopology(mesh)).signed_volume < 0.0) {
    for (Triangle& t : mesh.triangles) std::swap(t[1], t[2]);
  }
  return mesh;
}

Mesh MakeScan(const Mesh& object, ScanKind kind, bool held_out, int index) {
  const auto& poses = held_out ? kHeldOutPoses : kTuningPoses;
  return Scan(object, kind, poses[index % std::size(poses)], (held_out ? kHeldOutSeed : kTuningSeed) + index);
}

absl::StatusOr<std::vector<ScanKind>> ParseScanKinds(const std::string& s) {
  std::vector<ScanKind> kinds;
  for (absl::string_view k : absl::StrSplit(s, ',', absl::SkipEmpty())) {
    if (k == "tof") {
      kinds.push_back(ScanKind::kTimeOfFlight);
    } else if (k == "sl") {
      kinds.push_back(ScanKind::kStructuredLight);
    } else if (k == "fused") {
      kinds.push_back(ScanKind::kFused);
    } else {
      return absl::InvalidArgumentError(absl::StrCat("unknown scan kind '", std::string(k), "' (tof, sl, fused)"));
    }
  }
  return kinds;
}

absl::StatusOr<Quality> EvaluateOnSurface(const GroundTruth& clean, const Mesh& result, const Topology& topology,
                                          double h) {
  Quality q;
  const int32_t n = result.num_vertices();
  std::vector<char> used(n, 0);
  for (int32_t f : topology.faces) {
    for (int32_t v : result.triangles[f]) used[v] = 1;
  }
  for (int32_t v = 0; v < n; ++v) q.non_finite_vertices += used[v] && !IsFinite(result.positions[v]) ? 1 : 0;
  if (q.non_finite_vertices > 0) {
    q.rms_distance = q.max_distance = q.normal_error_deg = std::nan("");
    return q;
  }
  double sum2 = 0.0, max2 = 0.0;
  int64_t count = 0;
#pragma omp parallel for reduction(+ : sum2, count) reduction(max : max2) schedule(static)
  for (int32_t v = 0; v < n; ++v) {
    if (!used[v]) continue;
    const double d2 = clean.surface().SquaredDistance(result.positions[v]);
    sum2 += d2;
    max2 = std::max(max2, d2);
    ++count;
  }
  const auto faces = static_cast<int64_t>(topology.faces.size());
  double angle_sum = 0.0;
  int64_t measured = 0, flipped = 0;
  const Mesh& cm = clean.mesh();
#pragma omp parallel for reduction(+ : angle_sum, measured, flipped) schedule(static)
  for (int64_t i = 0; i < faces; ++i) {
    const Triangle& t = result.triangles[topology.faces[i]];
    const Vec3 &a = result.positions[t[0]], &b = result.positions[t[1]], &c = result.positions[t[2]];
    const Vec3 nr = Cross(b - a, c - a);
    const int32_t g = clean.surface().NearestTriangle((a + b + c) * (1.0 / 3.0));
    if (g < 0 || !(Norm(nr) > 0.0)) continue;
    const Triangle& u = cm.triangles[g];
    const Vec3 nc = Cross(cm.positions[u[1]] - cm.positions[u[0]], cm.positions[u[2]] - cm.positions[u[0]]);
    if (!(Norm(nc) > 0.0)) continue;
    angle_sum += std::atan2(Norm(Cross(nr, nc)), Dot(nr, nc)) * (180.0 / std::numbers::pi);
    flipped += Dot(nr, nc) < 0.0 ? 1 : 0;
    ++measured;
  }
  q.rms_distance = count > 0 ? std::sqrt(sum2 / count) / h : std::nan("");
  q.max_distance = std::sqrt(max2) / h;
  q.normal_error_deg = measured > 0 ? angle_sum / measured : std::nan("");
  q.crease_normal_error_deg = std::nan("");
  q.volume_change_percent = std::nan("");
  q.flipped_faces = flipped;
  const MeshMetrics m = ComputeMetrics(result, topology);
  q.edge_length_cv = m.edge_length_cv;
  q.min_angle_deg = m.min_angle_deg;
  return q;
}

void ScanSection(std::string& out, const ScanOptions& options, const std::vector<Job>& jobs,
                 const std::filesystem::path& meshes, const std::filesystem::path& real) {
  const Clock::time_point start = Clock::now();
  std::string summary, details;
  for (const std::string& name : options.meshes) {
    absl::StatusOr<Subject> subject = LoadSubject(name, meshes);
    if (!subject.ok()) {
      absl::StrAppendFormat(&summary, "| %s | skipped: %s |||||||||||\n", name, subject.status().ToString());
      continue;
    }
    const GroundTruth clean(ToObjectScale(subject->truth->mesh()));
    for (ScanKind kind : options.kinds) {
      std::vector<std::unique_ptr<ScanInput>> scans;
      for (int s = 0; s < options.seeds; ++s) {
        auto in = std::make_unique<ScanInput>();
        in->mesh = MakeScan(clean.mesh(), kind, options.held_out, s);
        in->topology = BuildTopology(in->mesh);
        in->h = MeanEdgeLength(in->mesh, in->topology);
        scans.push_back(std::move(in));
      }
      const std::vector<Input> inputs = InputsOf(clean, scans);
      const MeshCase mc{name, InputRow("noisy input", inputs),
                        JobRows(jobs, inputs, kind == ScanKind::kFused ? kFusedSweep : kFrameSweep)};
      const std::string label =
          absl::StrFormat("%s, %s (%d vertices)", name, KindName(kind), scans[0]->mesh.num_vertices());
      SummaryRow(summary, label, mc, kind == ScanKind::kFused ? kFusedSweep : kFrameSweep);
      DetailTable(details, KindName(kind), mc, options.seeds);
      std::fprintf(stderr, "scan %s: done at %.0f s\n", label.c_str(), Seconds(start, Clock::now()));
    }
  }
  std::string real_rows, real_details;
  if (options.real) {
    const std::filesystem::path noisy = real / "cone_noisy.obj.xz", truth = real / "cone_groundtruth.obj.xz";
    if (!std::filesystem::exists(noisy) || !std::filesystem::exists(truth)) {
      real_rows = absl::StrFormat("| real cone | skipped: %s absent |||||||||||\n", noisy.string());
    } else {
      char dir_template[] = "/tmp/meshsmooth-real-XXXXXX";
      const char* dir = mkdtemp(dir_template);
      absl::StatusOr<Mesh> n = dir ? ReadXz(noisy, dir) : absl::InternalError("mkdtemp failed");
      absl::StatusOr<Mesh> t = dir ? ReadXz(truth, dir) : absl::InternalError("mkdtemp failed");
      if (dir) std::filesystem::remove_all(dir);
      if (!n.ok() || !t.ok()) {
        real_rows = absl::StrFormat("| real cone | skipped: %s |||||||||||\n", (n.ok() ? t : n).status().ToString());
      } else {
        const GroundTruth gt(*std::move(t));
        const std::vector<Mesh> noisy_meshes = {*std::move(n)};
        const std::vector<Input> inputs = CopiesOf(gt, noisy_meshes);
        const MeshCase mc{"cone (real, Kinect-Fusion)", InputRow("noisy input", inputs),
                          JobRows(jobs, inputs, kFusedSweep)};
        SummaryRow(real_rows, "real cone, Kinect-Fusion (face for face)", mc, kFusedSweep);
        DetailTable(real_details, "real scan against its reference, face for face", mc, 1);
        std::fprintf(stderr, "real cone: done at %.0f s\n", Seconds(start, Clock::now()));
      }
    }
  }
  absl::StrAppendFormat(&out, "\n## Scans (%s seeds and poses)\n\n", options.held_out ? "held-out" : "tuning");
  out += kSummaryHeader + summary + real_rows;
  out += "\n### Every row, scan by scan\n" + details + real_details;
  absl::StrAppendFormat(&out, "\nThe scan cases took %.1f min.\n", Seconds(start, Clock::now()) / 60.0);
}

}  // namespace meshsmooth::bench
