// Between a mesh file and the service: what the CLI uploads for an input file and how it
// writes the result back, keeping what the service does not see (the input's colours, its
// coordinates' magnitude and precision).
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/mesh.h"
#include "core/vec3.h"

namespace meshsmooth::client {

struct Upload {
  std::string draco;        // what is sent
  std::vector<Rgb> colors;  // the input's vertex colours, for a PLY output
  // Positions were sent relative to this origin (LocalOrigin): zero for a mesh near the
  // origin, the rounded centre of a georeferenced one. Added back to the result.
  Vec3 origin;
  bool double_positions = false;      // write PLY coordinates as double
  std::vector<std::string> warnings;  // what the input lost on the way, one line each
};

// Draco input goes as it is (all its attributes travel along); anything else is read in
// double, moved to its local origin and encoded losslessly and sequentially, so vertex i of
// the result is vertex i of the input. The reader's errors when the input cannot be read.
absl::StatusOr<Upload> PrepareUpload(const std::string& input);

// Writes `result` (the service's Draco bytes) to `output` in the format its extension names:
// Draco bytes as they came, anything else decoded, moved back by the upload's origin, with the
// ridge labels (`ridges`) or the input's colours (vertex i of the result is vertex i) as vertex
// colours, PLY coordinates in double when the input had them or was shifted. Errors about the
// result itself start with "the result: ".
absl::Status WriteResult(const Upload& upload, const std::string& result, const std::string& output, bool ridges);

}  // namespace meshsmooth::client
