// Shared by the tests that build glTF scenes by hand: a float attribute on a Draco mesh and the
// small grey texture of their scenes.
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "core/render/image.h"
#include "core/render/png.h"
#include "draco/mesh/mesh.h"

namespace meshsmooth::testing {

// A float32 attribute of `type` with `components` values for each of `mesh`'s `points` points,
// one value per point (identity mapping).
inline draco::PointAttribute* AddFloatAttribute(draco::Mesh& mesh, draco::GeometryAttribute::Type type, int components,
                                                uint32_t points) {
  draco::GeometryAttribute ga;
  ga.Init(type, nullptr, components, draco::DT_FLOAT32, false, sizeof(float) * components, 0);
  return mesh.attribute(mesh.AddAttribute(ga, true, points));
}

// A 4 x 4 grey PNG: the texture of the small scenes.
inline absl::StatusOr<std::string> GreyPng() {
  Image image;
  image.width = image.height = 4;
  image.rgb.assign(3 * 4 * 4, 128);
  return EncodePng(image);
}

}  // namespace meshsmooth::testing
