// Whole files in one go: the one place the project reads or writes a file as a string of bytes
// (meshes, Draco bitstreams, certificates, token files).
#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace meshsmooth {

// The whole content of the file at `path`. Errors name the path and the system's reason, with
// the code errno maps to: "cannot open 'x.obj': No such file or directory" is NotFound,
// an unreadable file PermissionDenied, a directory FailedPrecondition ("cannot read ...").
absl::StatusOr<std::string> ReadFileBytes(const std::string& path);

// Writes `bytes` to `path` (created or truncated): PermissionDenied when it cannot be opened,
// DataLoss when writing fails.
absl::Status WriteFileBytes(const std::string& path, std::string_view bytes);

}  // namespace meshsmooth
