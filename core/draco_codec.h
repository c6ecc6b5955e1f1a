// Draco bytes <-> Mesh.
//
// The default (sequential, lossless) keeps vertex order and exact float32 positions, so vertex
// i of a decoded result is vertex i of what was encoded. Edgebreaker compresses better but
// reorders vertices and faces and drops isolated vertices. Quantization (1-30 bits) rounds
// each coordinate to a grid over the bounding box: error <= extent / (2^q - 1) / 2.
#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/mesh.h"

namespace meshsmooth {

enum class DracoMethod { kSequential, kEdgebreaker };

struct DracoOptions {
  int quantization_bits = 0;  // 0 = lossless (raw float32); otherwise 1..30
  DracoMethod method = DracoMethod::kSequential;
  int speed = 5;  // Draco's encoding/decoding speed, 0 (best compression) .. 10 (fastest)
};

// InvalidArgument for bad options or faces Draco cannot hold (indices out of range); positions
// are stored as float32.
absl::StatusOr<std::string> EncodeDraco(const Mesh& mesh, const DracoOptions& options = {});

// InvalidArgument with a clear message for corrupt bytes, a point cloud, an empty mesh or a
// mesh without positions. Vertices are Draco's points (attribute seams stay split).
absl::StatusOr<Mesh> DecodeDraco(std::string_view bytes);

}  // namespace meshsmooth
