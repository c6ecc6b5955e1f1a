#include "client/inputs.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/io/mesh_io.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"

namespace meshsmooth::client {

std::vector<std::pair<std::string, std::string>> BuiltinInputs() {
  return {
      {"noisy-sphere", "unit icosphere level 4 (2562 vertices), uniform noise 0.3 x mean edge, seed 1"},
      {"sphere", "unit icosphere level 4 (2562 vertices), no noise"},
      {"noisy-sphere-large", "unit icosphere level 6 (40962 vertices), uniform noise 0.3 x mean edge, seed 1"},
      {"noisy-torus", "torus sampled at two rates (32 / 16 around the tube), uniform noise 0.3 x mean edge, seed 1"},
      {"noisy-plane", "two-rate plane patch 48 x 32 with a boundary, uniform noise 0.3 x mean edge, seed 1"},
  };
}

absl::StatusOr<Mesh> LoadInput(const std::string& spec, ReadInfo* info) {
  const std::string kPrefix = "builtin:";
  if (!absl::StartsWith(spec, kPrefix)) return ReadMesh(spec, info);
  if (info != nullptr) *info = ReadInfo{};
  const std::string name = spec.substr(kPrefix.size());
  Mesh mesh;
  if (name == "noisy-sphere" || name == "sphere") {
    mesh = Icosphere(4);
  } else if (name == "noisy-sphere-large") {
    mesh = Icosphere(6);
  } else if (name == "noisy-torus") {
    mesh = TwoRateTorus(32);
  } else if (name == "noisy-plane") {
    mesh = TwoRatePlane(48, 32);
  } else {
    std::string names;
    for (const auto& [n, what] : BuiltinInputs()) absl::StrAppend(&names, names.empty() ? "" : ", ", n);
    return absl::InvalidArgumentError(absl::StrCat("unknown built-in input '", name, "' (known: ", names, ")"));
  }
  if (absl::StartsWith(name, "noisy-")) AddUniformNoise(mesh, 0.3, 1);
  return mesh;
}

}  // namespace meshsmooth::client
