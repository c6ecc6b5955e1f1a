// A small offscreen software renderer: one shaded picture of a mesh, for previews and reports.
//
// Orthographic camera on a direction around the mesh, z-buffered triangles, a directional
// light from the upper left of the viewer plus ambient light, flat or Gouraud shading, vertex
// colours when the mesh has them. Single-threaded; deterministic (same inputs, same pixels).
#pragma once

#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/mesh.h"
#include "core/render/image.h"

namespace meshsmooth {

// Where the camera sits, seen from the centre of the mesh's bounding box. +y is up.
// Azimuth turns about +y: 0 looks from +z (the front), 90 from +x (the right side).
// Elevation raises the camera toward +y: 90 looks straight down (image up = -z), -90 up.
struct View {
  double azimuth_deg = 30;
  double elevation_deg = 20;
  friend constexpr bool operator==(const View&, const View&) = default;
};

// The view named by `spec`: "front" (0,0), "back" (180,0), "left" (-90,0), "right" (90,0),
// "top" (0,90), "bottom" (0,-90), "iso" (45,35.26: along the (1,1,1) diagonal), or
// "AZ,EL" in degrees (e.g. "30,20"; elevation within [-90, 90]). InvalidArgument naming the
// accepted values otherwise.
absl::StatusOr<View> ParseView(std::string_view spec);

enum class Shading {
  kFlat,     // one normal per face: facets visible (vertex colours are still interpolated)
  kGouraud,  // area-weighted vertex normals, lighting interpolated over each face
};

// Image sides accepted by Render().
inline constexpr int kMinRenderSide = 16;
inline constexpr int kMaxRenderSide = 8192;

struct RenderOptions {
  int width = 800, height = 800;  // pixels, each in [kMinRenderSide, kMaxRenderSide]
  View view;
  Shading shading = Shading::kGouraud;
  Rgb background{255, 255, 255};
  Rgb base_color{180, 180, 180};  // the surface colour when the mesh has no vertex colours
  // Fraction of the shorter image side left free on each side of the framed mesh, in [0, 0.5).
  double margin = 0.05;
};

// Renders `mesh` with an orthographic camera looking at the centre c of the bounding box of
// the vertices that usable faces reference. The camera frames the sphere around c through the
// farthest such vertex (radius R), so every view of the mesh fits and the scale does not
// change with the view: R maps to (1 - 2 * margin) * min(width, height) / 2 pixels, centred
// in the image. Pixels are sampled at their centres.
//
// Lighting is two-sided (faces seen from behind are lit as if they faced the viewer, so open
// meshes and inconsistent orientation look right): ambient 0.25 plus 0.75 times the cosine to
// a light from the upper left of the viewer (35 degrees off the view direction), multiplying
// the vertex colour (or base_color).
//
// Faces that are not usable (IsUsableTriangle) are skipped. InvalidArgument for an empty mesh,
// a mesh without usable faces, a non-finite position, colours of the wrong count, or options
// out of range.
absl::StatusOr<Image> Render(const Mesh& mesh, const RenderOptions& options = {});

}  // namespace meshsmooth
