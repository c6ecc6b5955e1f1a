// The quality benchmark's inputs: the clean meshes that serve as ground truth (real meshes and
// synthetic shapes) and the noisy copies each noise case makes of them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/measure/evaluation.h"
#include "core/mesh.h"

namespace meshsmooth::bench {

// The real meshes that serve as ground truth (docs/quality-method.md says why these and not the
// beetle), then the synthetic shapes: the paper's, iso-surface output and two spheres with
// holes, the second an open scan's share of rims, a CAD part made of slivers and needle fans, and
// a detailed clean scan (the dragon decimated: its detail at the scale of an edge) (LoadSubject).
inline const std::vector<std::string> kDefaultMeshes = {
    "fandisk",        "bunny-small",       "max-planck",   "camelhead",      "turbine",  "nefertiti",
    "stanford-bunny", "stanford-dragon",   "sphere",       "two-rate-torus", "mt-torus", "mt-cylinder",
    "holey-sphere",   "perforated-sphere", "sliver-shaft", "dragon-8k"};

// Meshes from this many vertices get `large_seeds` seeds (unless it is 0).
inline constexpr int32_t kLargeMesh = 200000;

// kImpulsive: a scanner's outliers, kImpulsiveShare of the vertices thrown sigma h to 3 sigma h
// along their normals (AddImpulsiveNoise), the others clean.
enum class Noise { kNormal, kRandom, kImpulsive };
inline constexpr double kImpulsiveShare = 0.1;

// Gaussian noise of `sigma` h along the vertex normals or in random directions; sigma 0 is the
// clean mesh itself.
struct Case {
  Noise noise;
  double sigma;
  // The case as headings name it, e.g. "normal noise, sigma = 0.2 h".
  std::string Name() const;
};

// The cases of a run: `sigmas` along the normals, then the positive `random_sigmas` in random
// directions.
std::vector<Case> MakeCases(const std::vector<double>& sigmas, const std::vector<double>& random_sigmas,
                            const std::vector<double>& impulsive_scales = {});

// The clean mesh of a benchmark input and what it is.
struct Subject {
  std::string name, what;
  std::unique_ptr<GroundTruth> truth;
  double truth_seconds = 0.0;  // to build `truth`, on one thread
};

// The input `name`: a synthetic shape (`sphere`, `two-rate-torus`, `mt-torus`, `mt-cylinder`,
// `holey-sphere`, `perforated-sphere`, `sliver-shaft`), `dragon-8k` (stanford-dragon.ply in
// `meshes`, decimated), or NAME.obj, else NAME.ply, in `meshes`.
absl::StatusOr<Subject> LoadSubject(const std::string& name, const std::filesystem::path& meshes);

// The seconds one evaluation of `mesh` against `truth` takes on one thread; NaN if it fails.
double OneThreadEvaluationSeconds(const GroundTruth& truth, const Mesh& mesh);

// `clean` with the noise of `c` drawn from `seed`: the same bytes on every machine.
Mesh MakeNoisy(const Mesh& clean, const Case& c, uint64_t seed);

}  // namespace meshsmooth::bench
