#include "core/render/png.h"

#include <png.h>

#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"

namespace meshsmooth {

absl::StatusOr<std::string> EncodePng(const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != 3 * static_cast<size_t>(image.width) * static_cast<size_t>(image.height)) {
    return absl::InvalidArgumentError(absl::StrCat("cannot encode a ", image.width, "x", image.height,
                                                   " image holding ", image.rgb.size(), " bytes as PNG"));
  }
  // libpng's simplified API reports errors through its return value, so no setjmp/longjmp
  // crosses C++ frames here.
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format = PNG_FORMAT_RGB;
  const png_int_32 stride = 3 * image.width;
  // The worst-case size bound lets libpng compress once (asking for the size first would
  // compress twice).
  png_alloc_size_t size = PNG_IMAGE_PNG_SIZE_MAX(png);
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, image.rgb.data(), stride, nullptr)) {
    const std::string message = png.message;
    png_image_free(&png);
    return absl::InternalError(absl::StrCat("libpng: ", message));
  }
  bytes.resize(size);
  return bytes;
}

absl::Status WritePng(const std::string& path, const Image& image) {
  absl::StatusOr<std::string> bytes = EncodePng(image);
  if (!bytes.ok()) return bytes.status();
  return WriteFileBytes(path, *bytes);
}

}  // namespace meshsmooth
