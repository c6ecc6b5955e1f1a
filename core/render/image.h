// An 8-bit RGB picture in memory, as the renderer draws it and the PNG writer stores it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/mesh.h"

namespace meshsmooth {

// Row-major RGB, 3 bytes per pixel, top row first: rgb.size() == 3 * width * height.
struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;

  // The pixel in column x (from the left) and row y (from the top); both must be in range.
  Rgb pixel(int x, int y) const {
    const size_t i = 3 * (static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x));
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

}  // namespace meshsmooth
