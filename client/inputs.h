// Where the CLI gets a mesh: a file path, or a built-in generated shape named "builtin:NAME".
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/io/mesh_io.h"
#include "core/mesh.h"

namespace meshsmooth::client {

// Names accepted after "builtin:", with a one-line description each.
std::vector<std::pair<std::string, std::string>> BuiltinInputs();

// Loads `spec`: "builtin:NAME" generates the shape, anything else is read as a mesh file
// (what the reader noticed goes to `info` when given; a built-in shape leaves it empty).
absl::StatusOr<Mesh> LoadInput(const std::string& spec, ReadInfo* info = nullptr);

}  // namespace meshsmooth::client
