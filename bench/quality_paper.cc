#include "bench/quality_paper.h"

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "absl/strings/str_format.h"
#include "bench/bench_common.h"
#include "core/flows/flow.h"
#include "core/io/mesh_io.h"
#include "core/measure/evaluation.h"
#include "core/measure/metrics.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"

namespace meshsmooth::bench {
namespace {

void PaperRow(std::string& out, const std::string& label, const GroundTruth& truth, const Mesh& mesh) {
  const Quality q = *truth.Evaluate(mesh);
  const Topology& topo = truth.topology();
  double sq = 0.0;
  int64_t count = 0;
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kIsolated) continue;
    sq += SquaredNorm(mesh.positions[v] - truth.mesh().positions[v]);
    ++count;
  }
  const MeshMetrics m = ComputeMetrics(mesh, topo);
  absl::StrAppendFormat(&out, "| %s | %.4f | %+.2f%% | %.3f | %.2f | %d | %.4f | %.2f |\n", label,
                        std::sqrt(sq / count) / truth.mean_edge_length(),
                        100.0 * (m.signed_volume / truth.signed_volume() - 1.0), m.edge_length_cv, m.min_angle_deg,
                        q.flipped_faces, q.rms_distance, q.normal_error_deg);
}

void PaperTable(std::string& out, const std::string& title, const GroundTruth& truth, int iterations) {
  const Mesh& clean = truth.mesh();
  Mesh noisy = clean;
  AddUniformNoise(noisy, 0.3, 1);
  absl::StrAppendFormat(&out,
                        "\n### %s\n\n%d vertices, %d faces; uniform noise 0.30 x mean edge (seed 1); %d "
                        "iterations each.\n\n",
                        title, clean.num_vertices(), clean.num_triangles(), iterations);
  out +=
      "| flow | RMS distance to clean / h | volume change | edge-length CV | min angle (deg) | flipped normals | "
      "RMS distance to the clean surface / h | normal error (deg) |\n|---|---|---|---|---|---|---|---|\n";
  PaperRow(out, "clean mesh", truth, clean);
  PaperRow(out, "noisy input", truth, noisy);
  auto make = [iterations](const char* flow) {
    FlowParams p = DefaultParams(flow);
    p.iterations = iterations;
    return p;
  };
  FlowParams u1 = make("laplacian");
  u1.weights = UmbrellaWeights::kInverseDistance;
  FlowParams adaptive = make("median");
  adaptive.adaptive = AdaptiveMode::kRing2;
  const std::vector<std::pair<std::string, FlowParams>> variants = {
      {"laplacian U0 (step 0.5)", make("laplacian")},
      {"laplacian U1 (step 0.5)", u1},
      {"taubin U0 (0.5, k_PB 0.1)", make("taubin")},
      {"bilaplacian (step 0.2)", make("bilaplacian")},
      {"mcf (step 0.1 h^2)", make("mcf")},
      {"mcf_tangential (step 0.1 h^2, C 5)", make("mcf_tangential")},
      {"median (step 0.1 h^2, eps 0.1)", make("median")},
      {"median + adaptive T(P) 1+2 rings", adaptive}};
  Topology topo = truth.topology();  // lent to each run
  for (const auto& [label, params] : variants) {
    Mesh m = noisy;
    absl::StatusOr<FlowResult> r = Smooth(m, topo, params);
    if (!r.ok()) {
      absl::StrAppendFormat(&out, "| %s | failed: %s | | | | | | |\n", label, r.status().message());
      continue;
    }
    PaperRow(out, label, truth, m);
  }
}

}  // namespace

void PaperSection(std::string& out, const std::filesystem::path& mesh_dir, int iterations) {
  // How to read the tables: docs/quality-method.md, "The paper's setting".
  out += absl::StrFormat("\n## The paper's setting: %d iterations of each flow, uniform noise\n", iterations);
  PaperTable(out, "Noisy sphere (icosphere level 4)", GroundTruth(Icosphere(4)), iterations);
  PaperTable(out, "Noisy two-rate torus (Fig. 4)", GroundTruth(TwoRateTorus(32)), iterations);
  absl::StatusOr<Mesh> bunny = ReadMesh((mesh_dir / "stanford-bunny.ply").string());
  if (bunny.ok()) {
    PaperTable(out, "Noisy Stanford bunny (35,947 vertices, open, 5 holes)", GroundTruth(*std::move(bunny)),
               iterations);
  } else {
    absl::StrAppendFormat(&out, "\n### Noisy Stanford bunny\n\nskipped: %s\n", bunny.status().message());
  }
}

}  // namespace meshsmooth::bench
