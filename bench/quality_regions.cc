// The quality benchmark's rows with a region (docs/quality-regions.md): the default job given a
// per-vertex strength (FlowParams::strength) of 0 on part of a noisy mesh and 1 on the rest, against
// the same job on the whole mesh, both measured on the part that may move. A row holds when the
// part of strength 0 comes back bit for bit and the rest is within kMaxRatio of the whole-mesh
// job's error there.
//
//   build/bench/meshsmooth_quality_regions [--shared DIR] [--seeds N] > docs/quality-regions.md
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bench/bench_common.h"
#include "bench/quality_inputs.h"
#include "bench/quality_scans.h"
#include "core/job/default_job.h"
#include "core/measure/evaluation.h"
#include "core/measure/metrics.h"
#include "core/topology.h"

namespace meshsmooth::bench {
namespace {

constexpr double kMaxRatio = 1.05;
// The synthetic cases' held-out seeds, as meshsmooth_quality --held-out takes them.
constexpr uint64_t kFirstSeed = 1001;
// A rim: the vertices within this many edges of a boundary.
constexpr int kRimRings = 3;
// A sphere around the front-most vertex with this share of the bounding box's diagonal as radius.
constexpr double kSphereShare = 0.25;
// The edge of the free part: its vertices within this many edges of a held one, whose
// neighbours keep their noise whatever the job does.
constexpr int kEdgeRings = 3;

// Where a region keeps the input: strength 0 there, 1 elsewhere, on a mesh and its topology.
using StrengthOf = std::function<std::vector<float>(const Mesh&, const Topology&)>;

// One kind of input with a region: a noisy copy of a clean mesh (`noise`) or a simulated scan of
// it (`scan`), and the region.
struct RegionCase {
  std::string mesh, region;
  Case noise;
  std::optional<ScanKind> scan;
  StrengthOf strength;
};

// One noisy input of a row, its topology, h (the clean mesh's for a noisy copy, the scan's own
// for a scan) and the strength of its vertices.
struct RegionInput {
  Mesh mesh;
  Topology topology;
  double h = 0.0;
  bool copy = true;  // a noisy copy of the clean mesh: its faces are the clean mesh's
  std::vector<float> strength;
};

// The clean mesh's faces grouped across edges whose dihedral angle is below kCreaseAngleDeg (a
// CAD part's faces); strength 0 on the vertices of the group with the most faces.
std::vector<float> LargestSmoothPatchFixed(const Mesh& m, const Topology&) {
  const auto& tris = m.triangles;
  std::vector<Vec3> normal(tris.size());
  for (size_t f = 0; f < tris.size(); ++f) {
    const Vec3 c =
        Cross(m.positions[tris[f][1]] - m.positions[tris[f][0]], m.positions[tris[f][2]] - m.positions[tris[f][0]]);
    normal[f] = SquaredNorm(c) > 0.0 ? Normalized(c) : Vec3{};
  }
  std::map<std::pair<int32_t, int32_t>, std::vector<int32_t>> edge_faces;
  for (int32_t f = 0; f < static_cast<int32_t>(tris.size()); ++f) {
    for (int k = 0; k < 3; ++k) {
      const int32_t a = tris[f][k], b = tris[f][(k + 1) % 3];
      edge_faces[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  }
  // Union-find over faces.
  std::vector<int32_t> parent(tris.size());
  for (size_t f = 0; f < parent.size(); ++f) parent[f] = static_cast<int32_t>(f);
  std::function<int32_t(int32_t)> root = [&](int32_t f) { return parent[f] == f ? f : parent[f] = root(parent[f]); };
  const double cos_crease = std::cos(kCreaseAngleDeg * std::numbers::pi / 180.0);
  for (const auto& [edge, faces] : edge_faces) {
    if (faces.size() != 2 || Dot(normal[faces[0]], normal[faces[1]]) < cos_crease) continue;
    parent[root(faces[0])] = root(faces[1]);
  }
  std::vector<int32_t> size(tris.size(), 0);
  for (size_t f = 0; f < tris.size(); ++f) ++size[root(static_cast<int32_t>(f))];
  const int32_t largest = static_cast<int32_t>(std::max_element(size.begin(), size.end()) - size.begin());
  std::vector<float> strength(m.positions.size(), 1.0f);
  for (size_t f = 0; f < tris.size(); ++f) {
    if (root(static_cast<int32_t>(f)) != largest) continue;
    for (int32_t v : tris[f]) strength[v] = 0.0f;
  }
  return strength;
}

// The vertices within `rings` edges of one where `seed` holds (breadth-first over the one-rings).
template <typename Seed>
std::vector<uint8_t> WithinRings(const Topology& topo, int rings, Seed seed) {
  std::vector<uint8_t> near(topo.num_vertices(), 0);
  std::vector<int32_t> front;
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (seed(v)) near[v] = 1, front.push_back(v);
  }
  for (int ring = 1; ring <= rings; ++ring) {
    std::vector<int32_t> next;
    for (int32_t v : front) {
      for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) {
        if (!near[topo.ring[k]]) near[topo.ring[k]] = 1, next.push_back(topo.ring[k]);
      }
    }
    front = std::move(next);
  }
  return near;
}

// Strength 0 on the vertices within kRimRings edges of a boundary.
std::vector<float> RimFixed(const Mesh&, const Topology& topo) {
  const std::vector<uint8_t> rim =
      WithinRings(topo, kRimRings, [&topo](int32_t v) { return topo.kind[v] == VertexKind::kBoundary; });
  std::vector<float> strength(rim.size());
  for (size_t v = 0; v < rim.size(); ++v) strength[v] = rim[v] ? 0.0f : 1.0f;
  return strength;
}

// Strength 1 in a sphere around the front-most (largest z) vertex, 0 outside.
std::vector<float> FrontSphereSmoothed(const Mesh& m, const Topology&) {
  const std::vector<Vec3>& p = m.positions;
  Vec3 lo = p[0], hi = p[0];
  size_t front = 0;
  for (size_t v = 0; v < p.size(); ++v) {
    lo = {std::min(lo.x, p[v].x), std::min(lo.y, p[v].y), std::min(lo.z, p[v].z)};
    hi = {std::max(hi.x, p[v].x), std::max(hi.y, p[v].y), std::max(hi.z, p[v].z)};
    if (p[v].z > p[front].z) front = v;
  }
  const double r = kSphereShare * Norm(hi - lo);
  std::vector<float> strength(p.size());
  for (size_t v = 0; v < p.size(); ++v) strength[v] = Norm(p[v] - p[front]) <= r ? 1.0f : 0.0f;
  return strength;
}

// Strength 0 on the cap above y = 0.5 (of a unit sphere).
std::vector<float> CapFixed(const Mesh& m, const Topology&) {
  const std::vector<Vec3>& p = m.positions;
  std::vector<float> strength(p.size());
  for (size_t v = 0; v < p.size(); ++v) strength[v] = p[v].y > 0.5 ? 0.0f : 1.0f;
  return strength;
}

// The vertices of strength 1 (1) and, of those, the ones more than kEdgeRings edges from any vertex
// of strength below 1 (2); 0 for the rest.
std::vector<uint8_t> FreeParts(const Topology& topo, const std::vector<float>& strength) {
  const std::vector<uint8_t> edge =
      WithinRings(topo, kEdgeRings, [&strength](int32_t v) { return strength[v] < 1.0f; });
  std::vector<uint8_t> part(strength.size());
  for (size_t v = 0; v < part.size(); ++v) part[v] = strength[v] < 1.0f ? 0 : edge[v] ? 1 : 2;
  return part;
}

// The error of `result` on the vertices whose `part` is at least `least`: RMS distance to the
// clean surface (over h) and the mean angle between the normals of the faces with all three
// corners there and the clean ones (degrees): the same face of the clean mesh for a noisy copy,
// the clean triangle nearest to the face's centroid for a scan.
struct PartError {
  double rms_h = 0.0, normal_deg = 0.0;
};

PartError ErrorOn(const GroundTruth& truth, const RegionInput& in, const Mesh& result, const std::vector<uint8_t>& part,
                  uint8_t least) {
  double sum2 = 0.0, angles = 0.0;
  int64_t vertices = 0, faces = 0;
  for (size_t v = 0; v < part.size(); ++v) {
    if (part[v] < least || in.topology.kind[v] == VertexKind::kIsolated) continue;
    sum2 += truth.surface().SquaredDistance(result.positions[v]);
    ++vertices;
  }
  const Mesh& clean = truth.mesh();
  auto cross = [](const Mesh& m, const Triangle& t) {
    return Cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]);
  };
  for (int32_t f : in.topology.faces) {
    const Triangle& t = result.triangles[f];
    if (part[t[0]] < least || part[t[1]] < least || part[t[2]] < least) continue;
    const Vec3 b = cross(result, t);
    const int32_t g =
        in.copy ? f
                : truth.surface().NearestTriangle(
                      (result.positions[t[0]] + result.positions[t[1]] + result.positions[t[2]]) * (1.0 / 3.0));
    if (g < 0) continue;
    const Vec3 a = cross(clean, clean.triangles[g]);
    if (SquaredNorm(a) == 0.0 || SquaredNorm(b) == 0.0) continue;
    angles += std::acos(std::clamp(Dot(Normalized(a), Normalized(b)), -1.0, 1.0)) * 180.0 / std::numbers::pi;
    ++faces;
  }
  return {std::sqrt(sum2 / std::max<int64_t>(vertices, 1)) / in.h, angles / std::max<int64_t>(faces, 1)};
}

// The faces of `result` whose normal points against the clean one (GroundTruth::Evaluate for a
// noisy copy, EvaluateOnSurface for a scan).
int64_t FlippedFaces(const GroundTruth& truth, const RegionInput& in, const Mesh& result) {
  absl::StatusOr<Quality> q = in.copy ? truth.Evaluate(result) : EvaluateOnSurface(truth, result, in.topology, in.h);
  if (!q.ok()) {
    std::fprintf(stderr, "meshsmooth_quality_regions: %s\n", q.status().ToString().c_str());
    std::exit(1);
  }
  return q->flipped_faces;
}

// One seed of a row.
struct SeedRun {
  PartError noisy, whole, region;           // on the whole free part
  PartError noisy_in, whole_in, region_in;  // beyond its edge
  int64_t fixed_moved = 0;
  int64_t flipped_noisy = 0, flipped_whole = 0, flipped_region = 0;
  int iterations_whole = 0, iterations_region = 0;
  int64_t held = 0, vertices = 0;
};

// The default job on `in` with `strength` (empty: the whole mesh); its iterations go to
// `iterations`. Exits on a failed job.
Mesh DefaultJob(const RegionInput& in, const std::vector<float>& strength, int* iterations) {
  Mesh m = in.mesh;
  Topology topo = in.topology;  // lent to the job
  FlowParams p;
  p.strength = strength;
  absl::StatusOr<FlowResult> r = job::SmoothWithPolicy(m, topo, p, {}, job::kPolicy);
  if (!r.ok()) {
    std::fprintf(stderr, "meshsmooth_quality_regions: %s\n", r.status().ToString().c_str());
    std::exit(1);
  }
  *iterations = r->iterations_run;
  return m;
}

SeedRun RunSeed(const GroundTruth& truth, const RegionInput& in) {
  SeedRun s;
  s.held = std::count(in.strength.begin(), in.strength.end(), 0.0f);
  s.vertices = in.mesh.num_vertices();
  const std::vector<uint8_t> part = FreeParts(in.topology, in.strength);
  s.noisy = ErrorOn(truth, in, in.mesh, part, 1);
  s.noisy_in = ErrorOn(truth, in, in.mesh, part, 2);
  s.flipped_noisy = FlippedFaces(truth, in, in.mesh);
  const Mesh whole = DefaultJob(in, {}, &s.iterations_whole);
  const Mesh region = DefaultJob(in, in.strength, &s.iterations_region);
  s.flipped_whole = FlippedFaces(truth, in, whole);
  s.flipped_region = FlippedFaces(truth, in, region);
  s.whole = ErrorOn(truth, in, whole, part, 1);
  s.region = ErrorOn(truth, in, region, part, 1);
  s.whole_in = ErrorOn(truth, in, whole, part, 2);
  s.region_in = ErrorOn(truth, in, region, part, 2);
  for (size_t v = 0; v < in.strength.size(); ++v) {
    const Vec3 &a = region.positions[v], &b = in.mesh.positions[v];
    if (in.strength[v] == 0.0f && (a.x != b.x || a.y != b.y || a.z != b.z)) ++s.fixed_moved;
  }
  return s;
}

// Seed `s` of a case: a noisy copy of the clean mesh, or a scan of it (`object`, at object scale).
RegionInput MakeInput(const RegionCase& rc, const GroundTruth& truth, int s) {
  RegionInput in;
  if (rc.scan) {
    in.mesh = MakeScan(truth.mesh(), *rc.scan, /*held_out=*/true, s);
    in.topology = BuildTopology(in.mesh);
    in.h = MeanEdgeLength(in.mesh, in.topology);
    in.copy = false;
  } else {
    in.mesh = MakeNoisy(truth.mesh(), rc.noise, kFirstSeed + static_cast<uint64_t>(s));
    in.topology = truth.topology();
    in.h = truth.mean_edge_length();
  }
  // A copy's region is drawn on the clean mesh (the same for every seed), a scan's on the scan.
  in.strength = rc.scan ? rc.strength(in.mesh, in.topology) : rc.strength(truth.mesh(), truth.topology());
  return in;
}

void PrintHeader(int seeds) {
  std::printf("# Smoothing a region\n\n");
  std::printf(
      "Generated by `build/bench/meshsmooth_quality_regions --seeds %d > docs/quality-regions.md` "
      "(bench/quality_regions.cc), held-out seeds %llu to %llu.\n\n",
      seeds, static_cast<unsigned long long>(kFirstSeed), static_cast<unsigned long long>(kFirstSeed + seeds - 1));
  std::printf(
      "The default job with a per-vertex strength of 0 on part of the noisy mesh and 1 on the rest "
      "(`--fixed`, `--region` of the CLI; `JobSpec.strength_attribute`), against the same job on the "
      "whole mesh. \"moved\" counts vertices of strength 0 whose position is not bit for bit the input's; "
      "flipped faces are counted over the whole mesh. Errors are measured on the free part (strength 1): "
      "RMS distance of its vertices to the clean surface (h, the clean mean edge) and the mean normal "
      "error of its faces (degrees), on all of it and beyond its edge (the vertices more than %d edges "
      "from a held one: next to the held part a vertex's neighbours keep their noise whatever the job "
      "does). The ratio is region job / whole-mesh job, the worst seed. A row holds when nothing held "
      "moved, the region job has no more flipped faces than the noisy input, and both ratios beyond the "
      "edge are at most %.2f.\n\n",
      kEdgeRings, kMaxRatio);
  std::printf(
      "| mesh | noise | region | held vertices | moved | iterations whole / region | flipped noisy / whole / "
      "region | measured on | noisy RMS / θ | whole-mesh job RMS / θ | region job RMS / θ | worst ratio RMS / θ | "
      "holds |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
}

// The two rows of a case: the free part and beyond its edge.
void PrintRows(const RegionCase& rc, const std::vector<SeedRun>& runs) {
  auto mean = [&runs](auto field) {
    double sum = 0.0;
    for (const SeedRun& r : runs) sum += static_cast<double>(field(r));
    return sum / static_cast<double>(runs.size());
  };
  int64_t moved = 0;
  bool flips_ok = true;
  for (const SeedRun& r : runs) {
    moved += r.fixed_moved;
    flips_ok = flips_ok && r.flipped_region <= r.flipped_noisy;
  }
  for (const bool beyond : {false, true}) {
    auto pick = [beyond](const SeedRun& r, int which) -> const PartError& {
      const PartError* e[2][3] = {{&r.noisy, &r.whole, &r.region}, {&r.noisy_in, &r.whole_in, &r.region_in}};
      return *e[beyond][which];
    };
    double worst_rms = 0.0, worst_theta = 0.0;
    for (const SeedRun& r : runs) {
      worst_rms = std::max(worst_rms, pick(r, 2).rms_h / pick(r, 1).rms_h);
      worst_theta = std::max(worst_theta, pick(r, 2).normal_deg / pick(r, 1).normal_deg);
    }
    const bool holds = moved == 0 && flips_ok && worst_rms <= kMaxRatio && worst_theta <= kMaxRatio;
    std::string cells[3];
    for (int w = 0; w < 3; ++w) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.4f / %.2f°", mean([&](const SeedRun& r) { return pick(r, w).rms_h; }),
                    mean([&](const SeedRun& r) { return pick(r, w).normal_deg; }));
      cells[w] = buf;
    }
    std::printf(
        "| %s | %s | %s | %.0f of %.0f | %lld | %.0f / %.0f | %.0f / %.0f / %.0f | %s | %s | %s | %s | %.3f / %.3f | "
        "%s |\n",
        rc.mesh.c_str(), rc.scan ? "the scanner's" : rc.noise.Name().c_str(), rc.region.c_str(),
        mean([](const SeedRun& r) { return r.held; }), mean([](const SeedRun& r) { return r.vertices; }),
        static_cast<long long>(moved), mean([](const SeedRun& r) { return r.iterations_whole; }),
        mean([](const SeedRun& r) { return r.iterations_region; }),
        mean([](const SeedRun& r) { return r.flipped_noisy; }), mean([](const SeedRun& r) { return r.flipped_whole; }),
        mean([](const SeedRun& r) { return r.flipped_region; }),
        beyond ? ("beyond " + std::to_string(kEdgeRings) + " rings of the edge").c_str() : "the free part",
        cells[0].c_str(), cells[1].c_str(), cells[2].c_str(), worst_rms, worst_theta,
        beyond ? (holds ? "yes" : "**no**") : "");
  }
  std::fflush(stdout);
}

int Main(int argc, char** argv) {
  std::filesystem::path shared = std::filesystem::path(MESHSMOOTH_SOURCE_DIR) / ".." / "shared";
  int seeds = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--shared" && i + 1 < argc) {
      shared = argv[++i];
    } else if (a == "--seeds" && i + 1 < argc) {
      seeds = std::max(1, std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: meshsmooth_quality_regions [--shared DIR] [--seeds N]\n");
      return 2;
    }
  }
  const Case tof{Noise::kNormal, 0.0};  // a scan's noise is the scanner's
  const std::vector<RegionCase> cases = {
      {"fandisk",
       "its largest face (a crease-bounded patch) fixed",
       {Noise::kNormal, 0.2},
       {},
       LargestSmoothPatchFixed},
      {"stanford-bunny", "its rim (3 rings around the 5 holes) fixed", {Noise::kNormal, 0.2}, {}, RimFixed},
      {"camelhead", "its rim (3 rings around the neck's opening) fixed", {Noise::kRandom, 0.2}, {}, RimFixed},
      {"nefertiti", "a time-of-flight frame, its rim (3 rings) fixed", tof, ScanKind::kTimeOfFlight, RimFixed},
      {"max-planck", "only a sphere around the nose smoothed", {Noise::kNormal, 0.3}, {}, FrontSphereSmoothed},
      {"sphere", "the cap above y = 0.5 fixed", {Noise::kNormal, 0.3}, {}, CapFixed},
  };
  PrintHeader(seeds);
  for (const RegionCase& rc : cases) {
    absl::StatusOr<Subject> subject = LoadSubject(rc.mesh, shared / "data" / "meshes");
    if (!subject.ok()) {
      std::fprintf(stderr, "meshsmooth_quality_regions: %s\n", subject.status().ToString().c_str());
      return 1;
    }
    // A scan is of the object at its size (ToObjectScale), measured against it.
    const GroundTruth object(ToObjectScale(subject->truth->mesh()));
    const GroundTruth& truth = rc.scan ? object : *subject->truth;
    std::vector<SeedRun> runs;
    for (int s = 0; s < seeds; ++s) runs.push_back(RunSeed(truth, MakeInput(rc, truth, s)));
    PrintRows(rc, runs);
  }
  std::printf("\nFigures are means over the seeds, but for the worst ratio and \"moved\" (a sum).\n");
  return 0;
}

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) { return meshsmooth::bench::Main(argc, argv); }
