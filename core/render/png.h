// PNG output for rendered images (Debian's libpng).
#pragma once

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/render/image.h"

namespace meshsmooth {

// The image as the bytes of an 8-bit RGB PNG file. InvalidArgument when the image is empty
// or its pixel buffer does not hold 3 * width * height bytes; Internal if libpng fails.
absl::StatusOr<std::string> EncodePng(const Image& image);

// Encodes and writes `path` (replacing it). EncodePng's errors; PermissionDenied when the file
// cannot be created, DataLoss when writing it fails.
absl::Status WritePng(const std::string& path, const Image& image);

}  // namespace meshsmooth
