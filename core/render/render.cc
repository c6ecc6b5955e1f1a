#include "core/render/render.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/normals.h"
#include "core/render/raster.h"

namespace meshsmooth {
namespace {

constexpr double kAmbient = 0.25;
constexpr double kDiffuse = 0.75;

bool ParseNumber(std::string_view s, double& out) {
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return !s.empty() && ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}

// One corner of a face on its way to the screen.
struct Corner {
  raster::ScreenPoint p;
  double z;      // toward the camera: larger is nearer
  float rgb[3];  // lit colour, 0..255
};

class Rasterizer {
 public:
  Rasterizer(Image& image, std::vector<float>& depth) : image_(image), depth_(depth) {}

  // Fills the face's pixels that are nearer than what is there, interpolating depth and colour
  // linearly (orthographic projection: screen-space interpolation is exact).
  void Draw(const Corner& c0, const Corner& c1, const Corner& c2) {
    raster::ForEachCoveredPixel(image_.width, image_.height, c0.p, c1.p, c2.p,
                                [&](size_t index, double l0, double l1, double l2) {
                                  const float z = static_cast<float>(l0 * c0.z + l1 * c1.z + l2 * c2.z);
                                  if (!(z > depth_[index])) return;
                                  depth_[index] = z;
                                  uint8_t* out = &image_.rgb[3 * index];
                                  for (int ch = 0; ch < 3; ++ch) {
                                    const double value = l0 * c0.rgb[ch] + l1 * c1.rgb[ch] + l2 * c2.rgb[ch];
                                    out[ch] = static_cast<uint8_t>(std::clamp(value + 0.5, 0.0, 255.0));
                                  }
                                });
  }

 private:
  Image& image_;
  std::vector<float>& depth_;
};

absl::Status ValidateOptions(const RenderOptions& o) {
  for (const auto& [name, side] : {std::pair{"width", o.width}, std::pair{"height", o.height}}) {
    if (side < kMinRenderSide || side > kMaxRenderSide) {
      return absl::InvalidArgumentError(
          absl::StrCat("render ", name, " must be in [", kMinRenderSide, ", ", kMaxRenderSide, "] pixels, got ", side));
    }
  }
  if (!(o.margin >= 0.0 && o.margin < 0.5)) {
    return absl::InvalidArgumentError(absl::StrCat("render margin must be in [0, 0.5), got ", o.margin));
  }
  if (!std::isfinite(o.view.azimuth_deg) || !(std::fabs(o.view.elevation_deg) <= 90.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the view needs a finite azimuth and an elevation in [-90, 90], got ", o.view.azimuth_deg, ",",
                     o.view.elevation_deg));
  }
  if (o.shading != Shading::kFlat && o.shading != Shading::kGouraud) {
    return absl::InvalidArgumentError("unknown shading");
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<View> ParseView(std::string_view spec) {
  static constexpr std::pair<std::string_view, View> kNamed[] = {
      {"front", {0, 0}},
      {"back", {180, 0}},
      {"left", {-90, 0}},
      {"right", {90, 0}},
      {"top", {0, 90}},
      {"bottom", {0, -90}},
      // Elevation atan(1 / sqrt(2)): the camera on the (1, 1, 1) diagonal.
      {"iso", {45, 35.264389682754654}},
  };
  for (const auto& [name, view] : kNamed) {
    if (spec == name) return view;
  }
  const size_t comma = spec.find(',');
  View v;
  if (comma != std::string_view::npos && ParseNumber(spec.substr(0, comma), v.azimuth_deg) &&
      ParseNumber(spec.substr(comma + 1), v.elevation_deg) && std::fabs(v.elevation_deg) <= 90.0) {
    return v;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown view '", std::string(spec),
                   "': use front, back, left, right, top, bottom, iso, or AZ,EL in degrees "
                   "(azimuth about +y from +z, elevation in [-90, 90], e.g. 30,20)"));
}

absl::StatusOr<Image> Render(const Mesh& mesh, const RenderOptions& options) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  const int32_t n = mesh.num_vertices();
  if (n == 0 || mesh.triangles.empty()) {
    return absl::InvalidArgumentError("cannot render an empty mesh");
  }
  if (!mesh.colors.empty() && mesh.colors.size() != mesh.positions.size()) {
    return absl::InvalidArgumentError(absl::StrCat("the mesh has ", mesh.colors.size(), " colours for ", n,
                                                   " vertices (want one per vertex or none)"));
  }
  for (int32_t i = 0; i < n; ++i) {
    if (!IsFinite(mesh.positions[i])) {
      return absl::InvalidArgumentError(absl::StrCat("vertex ", i, " has a non-finite position"));
    }
  }

  // Frame only what is drawn: a stray unreferenced vertex must not shrink the picture.
  std::vector<char> used(n, 0);
  bool any_face = false;
  for (const Triangle& t : mesh.triangles) {
    if (!IsUsableTriangle(t, n)) continue;
    any_face = true;
    for (int32_t v : t) used[v] = 1;
  }
  if (!any_face) return absl::InvalidArgumentError("the mesh has no usable face to render");
  BoundingBox box;
  for (int32_t i = 0; i < n; ++i) {
    if (used[i]) box.Add(mesh.positions[i]);
  }
  // Offsets from the centre are measured in box extents first, so neither tiny (1e-200) nor
  // huge coordinates underflow or overflow in the norms below.
  const Vec3 center = box.lo + 0.5 * (box.hi - box.lo);
  double extent = box.max_extent();
  if (!std::isfinite(extent) || !IsFinite(center)) {
    return absl::InvalidArgumentError("the mesh's coordinates span too large a range to render");
  }
  if (!(extent > 0.0)) extent = 1.0;  // every vertex in one point: nothing has area anyway
  auto offset = [&](const Vec3& p) {
    const Vec3 d = p - center;
    return Vec3{d.x / extent, d.y / extent, d.z / extent};
  };
  double radius = 0.0;  // in extents: between 1/2 and sqrt(3)/2 (or 0)
  for (int32_t i = 0; i < n; ++i) {
    if (used[i]) radius = std::max(radius, Norm(offset(mesh.positions[i])));
  }
  if (!(radius > 0.0)) radius = 1.0;

  // Camera frame: `toward` points from the centre to the camera; right and up span the image.
  const double az = options.view.azimuth_deg * std::numbers::pi / 180.0;
  const double el = options.view.elevation_deg * std::numbers::pi / 180.0;
  const Vec3 toward{std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)};
  const Vec3 right{std::cos(az), 0.0, -std::sin(az)};  // horizontal, so no pole singularity
  const Vec3 up = Cross(toward, right);
  const Vec3 light_sum = 2.0 * toward + up - right;  // upper left, 35 degrees off the view axis
  const Vec3 light = light_sum * (1.0 / Norm(light_sum));

  const int w = options.width, h = options.height;
  const double framed_pixels = (1.0 - 2.0 * options.margin) * 0.5 * std::min(w, h);  // radius on screen
  // Positions moved into the unit ball: projection and normals then work at any mesh scale
  // (a uniform scale changes no normal's direction).
  std::vector<Vec3> local(n);
  std::vector<Corner> screen(n);
  for (int32_t i = 0; i < n; ++i) {
    if (!used[i]) continue;
    const Vec3 d = local[i] = offset(mesh.positions[i]) * (1.0 / radius);
    Corner& c = screen[i];
    c.p.x = raster::ToFixed(0.5 * w + framed_pixels * Dot(d, right));
    c.p.y = raster::ToFixed(0.5 * h - framed_pixels * Dot(d, up));  // rows grow downward
    c.z = Dot(d, toward);
  }

  const bool gouraud = options.shading == Shading::kGouraud;
  const std::vector<Vec3> normals = gouraud ? VertexNormals(local, mesh.triangles) : std::vector<Vec3>();
  auto base = [&](int32_t v) { return mesh.colors.empty() ? options.base_color : mesh.colors[v]; };
  auto lit = [&](Corner& c, const Rgb& color, double cosine) {
    const double k = kAmbient + kDiffuse * std::max(0.0, cosine);
    c.rgb[0] = static_cast<float>(k * color.r);
    c.rgb[1] = static_cast<float>(k * color.g);
    c.rgb[2] = static_cast<float>(k * color.b);
  };

  Image image;
  image.width = w;
  image.height = h;
  image.rgb.resize(3 * static_cast<size_t>(w) * static_cast<size_t>(h));
  for (size_t i = 0; i < image.rgb.size(); i += 3) {
    image.rgb[i] = options.background.r;
    image.rgb[i + 1] = options.background.g;
    image.rgb[i + 2] = options.background.b;
  }
  std::vector<float> depth(static_cast<size_t>(w) * static_cast<size_t>(h), -std::numeric_limits<float>::infinity());
  Rasterizer raster(image, depth);
  for (const Triangle& t : mesh.triangles) {
    if (!IsUsableTriangle(t, n)) continue;
    const Vec3& a = local[t[0]];
    const Vec3 face = Cross(local[t[1]] - a, local[t[2]] - a);
    const double face_len = Norm(face);
    // Two-sided: light the side the viewer sees.
    const Vec3 seen = Dot(face, toward) >= 0.0 ? face : -face;
    const double face_cosine = face_len > 0.0 ? Dot(seen, light) / face_len : 0.0;
    Corner c[3];
    for (int k = 0; k < 3; ++k) {
      c[k] = screen[t[k]];
      double cosine = face_cosine;
      if (gouraud) {
        const Vec3& nv = normals[t[k]];
        // The vertex normal turned to the seen side of this face: right for open meshes seen
        // from behind and for faces wound against their neighbours.
        if (nv != Vec3{}) cosine = Dot(nv, seen) >= 0.0 ? Dot(nv, light) : -Dot(nv, light);
      }
      lit(c[k], base(t[k]), cosine);
    }
    raster.Draw(c[0], c[1], c[2]);
  }
  return image;
}

}  // namespace meshsmooth
