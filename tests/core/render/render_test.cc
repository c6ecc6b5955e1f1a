#include "core/render/render.h"

#include <png.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <numbers>

#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/render/png.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/test_data.h"

namespace meshsmooth {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = std::numbers::pi;

// The radius in pixels that Render() gives the framing sphere (its documented contract).
double FramedRadiusPixels(const RenderOptions& o) { return (1.0 - 2.0 * o.margin) * 0.5 * std::min(o.width, o.height); }

bool IsBackground(const Image& img, int x, int y, const RenderOptions& o) { return img.pixel(x, y) == o.background; }

int64_t CoveredPixels(const Image& img, const RenderOptions& o) {
  int64_t n = 0;
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) n += IsBackground(img, x, y, o) ? 0 : 1;
  }
  return n;
}

double Intensity(const Rgb& c) { return (c.r + c.g + c.b) / 3.0; }

RenderOptions Front(int side = 400) {
  RenderOptions o;
  o.width = o.height = side;
  o.view = *ParseView("front");
  return o;
}

// A unit sphere (all vertices at distance 1 from the box centre, so the framing radius is 1)
// covers the disc of the framed radius, less the sliver between the circle and the inscribed
// polyhedron's outline; the disc is centred.
TEST(RenderTest, SphereCoversTheFramedDisc) {
  const Mesh sphere = Icosphere(5);
  struct Case {
    int width, height;
    const char* view;
    double margin;
  };
  for (const Case& c : {Case{800, 800, "30,20", 0.05}, Case{640, 400, "iso", 0.05}, Case{300, 500, "top", 0.2}}) {
    RenderOptions o;
    o.width = c.width;
    o.height = c.height;
    o.view = *ParseView(c.view);
    o.margin = c.margin;
    absl::StatusOr<Image> img = Render(sphere, o);
    ASSERT_TRUE(img.ok()) << img.status();
    ASSERT_EQ(img->width, c.width);
    ASSERT_EQ(img->height, c.height);
    ASSERT_EQ(img->rgb.size(), 3u * c.width * c.height);
    const double r = FramedRadiusPixels(o);
    const double disc = kPi * r * r;
    double sx = 0, sy = 0;
    int64_t covered = 0;
    for (int y = 0; y < img->height; ++y) {
      for (int x = 0; x < img->width; ++x) {
        if (IsBackground(*img, x, y, o)) continue;
        ++covered;
        sx += x + 0.5;
        sy += y + 0.5;
      }
    }
    std::printf("%dx%d view %s margin %g: %lld covered pixels, pi R^2 = %.0f (R = %.1f px), ratio %.4f\n", c.width,
                c.height, c.view, c.margin, static_cast<long long>(covered), disc, r, covered / disc);
    EXPECT_NEAR(covered / disc, 1.0, 0.03) << c.view;
    EXPECT_NEAR(sx / covered, 0.5 * c.width, 0.5) << c.view;
    EXPECT_NEAR(sy / covered, 0.5 * c.height, 0.5) << c.view;
  }
}

// The light comes from the upper left of the viewer: on a sphere the upper-left half of the
// disc is brighter than the lower-right half.
TEST(RenderTest, LitSideIsBrighter) {
  for (Shading shading : {Shading::kGouraud, Shading::kFlat}) {
    RenderOptions o;
    o.shading = shading;
    const Image img = *Render(Icosphere(5), o);
    double lit = 0, shaded = 0;
    int64_t n_lit = 0, n_shaded = 0;
    for (int y = 0; y < img.height; ++y) {
      for (int x = 0; x < img.width; ++x) {
        if (IsBackground(img, x, y, o)) continue;
        const double along = (x + 0.5 - 0.5 * img.width) + (y + 0.5 - 0.5 * img.height);  // toward lower right
        if (along < 0) {
          lit += Intensity(img.pixel(x, y));
          ++n_lit;
        } else {
          shaded += Intensity(img.pixel(x, y));
          ++n_shaded;
        }
      }
    }
    lit /= n_lit;
    shaded /= n_shaded;
    std::printf("%s: mean intensity upper-left half %.1f, lower-right half %.1f\n",
                shading == Shading::kFlat ? "flat" : "gouraud", lit, shaded);
    EXPECT_GT(lit, shaded + 30.0);
    // Nothing brighter than the fully lit base colour, nothing darker than its ambient part.
    EXPECT_LE(lit, 180.0);
    EXPECT_GE(shaded, 0.25 * 180.0 - 1.0);
  }
}

// Half the sphere (x > 0.2) red: seen from the front (+x to the right), red appears only right
// of the centre and fills the disc segment beyond x = 0.2.
TEST(RenderTest, VertexColoursShowWhereTheyAre) {
  Mesh sphere = Icosphere(5);
  const Rgb red{220, 30, 30}, grey{180, 180, 180};
  for (const Vec3& p : sphere.positions) sphere.colors.push_back(p.x > 0.2 ? red : grey);
  const RenderOptions o = Front(800);
  const Image img = *Render(sphere, o);
  const double r = FramedRadiusPixels(o);
  int64_t red_pixels = 0, misplaced = 0;
  for (int y = 0; y < img.height; ++y) {
    for (int x = 0; x < img.width; ++x) {
      const Rgb c = img.pixel(x, y);
      if (c.r <= c.g + 20) continue;
      ++red_pixels;
      // One edge of the level-5 sphere (~0.04) may blend red toward the centre.
      if ((x + 0.5 - 0.5 * img.width) / r < 0.2 - 0.06) ++misplaced;
    }
  }
  const double segment = (std::acos(0.2) - 0.2 * std::sqrt(1 - 0.2 * 0.2)) * r * r;  // circle beyond x = 0.2 r
  std::printf("red pixels %lld, disc segment beyond x = 0.2 R: %.0f (ratio %.3f)\n", static_cast<long long>(red_pixels),
              segment, red_pixels / segment);
  EXPECT_EQ(misplaced, 0);
  EXPECT_NEAR(red_pixels / segment, 1.0, 0.08);
  // The grey side keeps its grey.
  const Rgb left = img.pixel(img.width / 2 - static_cast<int>(0.5 * r), img.height / 2);
  EXPECT_EQ(left.r, left.g);
  EXPECT_EQ(left.g, left.b);
}

// Flat shading is constant over each face, Gouraud varies inside it; both cover exactly the
// same pixels. Faces are located by the documented framing (front view: image x = cx + R x,
// image y = cy - R y for the unit sphere).
TEST(RenderTest, FlatAndGouraudDiffer) {
  const Mesh sphere = Icosphere(2);  // 320 faces: facets tens of pixels wide
  RenderOptions o = Front(400);
  o.shading = Shading::kFlat;
  const Image flat = *Render(sphere, o);
  o.shading = Shading::kGouraud;
  const Image smooth = *Render(sphere, o);
  int64_t differ = 0, covered = 0;
  for (int y = 0; y < flat.height; ++y) {
    for (int x = 0; x < flat.width; ++x) {
      ASSERT_EQ(IsBackground(flat, x, y, o), IsBackground(smooth, x, y, o)) << x << "," << y;
      if (IsBackground(flat, x, y, o)) continue;
      ++covered;
      differ += flat.pixel(x, y) == smooth.pixel(x, y) ? 0 : 1;
    }
  }
  const double r = FramedRadiusPixels(o);
  int faces = 0, flat_uniform = 0, smooth_varied = 0;
  for (const Triangle& t : sphere.triangles) {
    const Vec3 centroid = (sphere.positions[t[0]] + sphere.positions[t[1]] + sphere.positions[t[2]]) * (1.0 / 3);
    if (centroid.z < 0.5) continue;  // seen obliquely or from behind
    ++faces;
    int flat_lo = 255, flat_hi = 0, smooth_lo = 255, smooth_hi = 0;
    for (const Vec3 w : {Vec3{0.6, 0.2, 0.2}, Vec3{0.2, 0.6, 0.2}, Vec3{0.2, 0.2, 0.6}, Vec3{1, 1, 1} * (1.0 / 3)}) {
      const Vec3 p = sphere.positions[t[0]] * w.x + sphere.positions[t[1]] * w.y + sphere.positions[t[2]] * w.z;
      const int x = static_cast<int>(0.5 * o.width + r * p.x), y = static_cast<int>(0.5 * o.height - r * p.y);
      const int a = flat.pixel(x, y).r, b = smooth.pixel(x, y).r;
      flat_lo = std::min(flat_lo, a);
      flat_hi = std::max(flat_hi, a);
      smooth_lo = std::min(smooth_lo, b);
      smooth_hi = std::max(smooth_hi, b);
    }
    flat_uniform += flat_lo == flat_hi ? 1 : 0;
    smooth_varied += smooth_hi - smooth_lo >= 3 ? 1 : 0;
  }
  std::printf("%lld of %lld pixels differ; of %d front faces %d uniform when flat, %d varied with gouraud\n",
              static_cast<long long>(differ), static_cast<long long>(covered), faces, flat_uniform, smooth_varied);
  EXPECT_GT(faces, 50);
  EXPECT_EQ(flat_uniform, faces);
  EXPECT_GT(smooth_varied, 0.8 * faces);
  EXPECT_GT(differ, covered / 2);
}

// Two-sided lighting: an open patch seen from behind is lit like its front (the light follows
// the camera), not left dark.
TEST(RenderTest, OpenMeshIsLitFromBothSides) {
  const Mesh plane = TwoRatePlane(24, 16);  // z = 0, normals +z
  RenderOptions o = Front(200);
  const Image front = *Render(plane, o);
  o.view = *ParseView("back");
  const Image back = *Render(plane, o);
  const Rgb f = front.pixel(100, 100), b = back.pixel(100, 100);
  EXPECT_NE(f, o.background);
  EXPECT_EQ(f, b);
  EXPECT_GT(Intensity(f), 0.8 * 180);  // the light is 35 degrees off the normal: cos = 0.82
  EXPECT_EQ(CoveredPixels(front, o), CoveredPixels(back, o));
}

// The nearer of two overlapping squares wins whatever the face order.
TEST(RenderTest, NearerSurfaceHidesFartherOne) {
  Mesh m;
  m.positions = {{-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1},    // near (z = 1), red
                 {-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1}};  // far (z = -1), blue
  m.colors = {{255, 0, 0}, {255, 0, 0}, {255, 0, 0}, {255, 0, 0}, {0, 0, 255}, {0, 0, 255}, {0, 0, 255}, {0, 0, 255}};
  const std::vector<Triangle> near = {{0, 1, 2}, {0, 2, 3}}, far = {{4, 5, 6}, {4, 6, 7}};
  for (bool near_first : {true, false}) {
    m.triangles = near_first ? near : far;
    const std::vector<Triangle>& second = near_first ? far : near;
    m.triangles.insert(m.triangles.end(), second.begin(), second.end());
    const Image img = *Render(m, Front(64));
    const Rgb c = img.pixel(32, 32);
    EXPECT_GT(c.r, 100) << near_first;
    EXPECT_EQ(c.b, 0) << near_first;
  }
}

TEST(RenderTest, ParseViewAcceptsNamesAndAngles) {
  EXPECT_EQ(*ParseView("front"), (View{0, 0}));
  EXPECT_EQ(*ParseView("back"), (View{180, 0}));
  EXPECT_EQ(*ParseView("left"), (View{-90, 0}));
  EXPECT_EQ(*ParseView("right"), (View{90, 0}));
  EXPECT_EQ(*ParseView("top"), (View{0, 90}));
  EXPECT_EQ(*ParseView("bottom"), (View{0, -90}));
  EXPECT_NEAR(ParseView("iso")->elevation_deg, std::atan(1 / std::sqrt(2.0)) * 180 / kPi, 1e-12);
  EXPECT_EQ(*ParseView("30,20"), (View{30, 20}));
  EXPECT_EQ(*ParseView(" -45.5 , +10 "), (View{-45.5, 10}));
  EXPECT_EQ(*ParseView("400,-90"), (View{400, -90}));
  for (const char* bad :
       {"", "sideways", "Front", "30", "30,", ",20", "30,95", "30,-90.5", "nan,0", "30,20,10", "inf,0", "30;20"}) {
    absl::StatusOr<View> v = ParseView(bad);
    ASSERT_FALSE(v.ok()) << bad;
    EXPECT_EQ(v.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(v.status().message().find("front, back, left, right, top, bottom, iso"), std::string::npos);
    EXPECT_NE(v.status().message().find("AZ,EL"), std::string::npos);
  }
}

TEST(RenderTest, BadInputsAreInvalidArgument) {
  const Mesh sphere = Icosphere(1);
  auto expect_invalid = [](const absl::StatusOr<Image>& img, const char* what) {
    ASSERT_FALSE(img.ok()) << what;
    EXPECT_EQ(img.status().code(), absl::StatusCode::kInvalidArgument) << what << ": " << img.status();
  };
  expect_invalid(Render(Mesh{}, {}), "empty mesh");
  Mesh points = sphere;
  points.triangles.clear();
  expect_invalid(Render(points, {}), "no faces");
  Mesh unusable = sphere;
  unusable.triangles = {{0, 0, 1}, {-1, 2, 3}, {1, 2, 1000}};
  expect_invalid(Render(unusable, {}), "no usable face");
  Mesh nan = sphere;
  nan.positions[5].y = std::nan("");
  expect_invalid(Render(nan, {}), "NaN");
  Mesh inf = sphere;
  inf.positions[0].x = HUGE_VAL;
  expect_invalid(Render(inf, {}), "infinity");
  Mesh colors = sphere;
  colors.colors.resize(3);
  expect_invalid(Render(colors, {}), "colour count");

  struct OptionCase {
    const char* what;
    void (*set)(RenderOptions&);
  };
  const OptionCase cases[] = {
      {"width 15", [](RenderOptions& o) { o.width = kMinRenderSide - 1; }},
      {"height 8193", [](RenderOptions& o) { o.height = kMaxRenderSide + 1; }},
      {"height 0", [](RenderOptions& o) { o.height = 0; }},
      {"width -800", [](RenderOptions& o) { o.width = -800; }},
      {"margin 0.5", [](RenderOptions& o) { o.margin = 0.5; }},
      {"margin -0.01", [](RenderOptions& o) { o.margin = -0.01; }},
      {"margin NaN", [](RenderOptions& o) { o.margin = std::nan(""); }},
      {"elevation 91", [](RenderOptions& o) { o.view.elevation_deg = 91; }},
      {"azimuth inf", [](RenderOptions& o) { o.view.azimuth_deg = HUGE_VAL; }},
      {"shading 7", [](RenderOptions& o) { o.shading = static_cast<Shading>(7); }},
  };
  for (const OptionCase& c : cases) {
    RenderOptions o;
    c.set(o);
    expect_invalid(Render(sphere, o), c.what);
  }
  RenderOptions smallest = Front(kMinRenderSide);
  EXPECT_TRUE(Render(sphere, smallest).ok());
}

// Unusable faces are skipped; an unreferenced vertex far away does not change the framing.
TEST(RenderTest, BadFacesAndStrayVerticesAreLeftOut) {
  const Mesh sphere = Icosphere(3);
  const Image clean = *Render(sphere, Front(200));
  Mesh dirty = sphere;
  dirty.triangles.push_back({0, 0, 1});
  dirty.triangles.push_back({-1, 2, 3});
  dirty.positions.push_back({100, 100, 100});  // referenced by no usable face
  dirty.triangles.push_back({1, 2, dirty.num_vertices()});
  const Image img = *Render(dirty, Front(200));
  EXPECT_EQ(img.rgb, clean.rgb);
}

// The picture does not depend on the mesh's scale or place: tiny and huge spheres (scaled by
// powers of two, so exactly) give the same pixels as the unit sphere, a moved one nearly so.
TEST(RenderTest, ScaleAndPositionDoNotMatter) {
  const Mesh sphere = Icosphere(3);
  const RenderOptions o = Front(200);
  const Image unit = *Render(sphere, o);
  for (double scale : {std::ldexp(1.0, -500), std::ldexp(1.0, 500)}) {
    Mesh m = sphere;
    for (Vec3& p : m.positions) p *= scale;
    absl::StatusOr<Image> img = Render(m, o);
    ASSERT_TRUE(img.ok()) << img.status();
    EXPECT_EQ(img->rgb, unit.rgb) << scale;
  }
  Mesh moved = sphere;
  for (Vec3& p : moved.positions) p += Vec3{1000, -2000, 3000};
  const Image img = *Render(moved, o);
  int64_t differ = 0;
  for (size_t i = 0; i < img.rgb.size(); ++i) differ += std::abs(img.rgb[i] - unit.rgb[i]) > 1 ? 1 : 0;
  EXPECT_LT(differ, 20);
  // A range that overflows a double cannot be framed.
  Mesh wide = sphere;
  wide.positions[0].x = -1.5e308;
  wide.positions[1].x = 1.5e308;
  EXPECT_EQ(Render(wide, o).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(RenderTest, PngEncodesAndDecodesBack) {
  RenderOptions o = Front(97);  // odd sizes, not square
  o.height = 61;
  Mesh sphere = Icosphere(3);
  for (const Vec3& p : sphere.positions) {
    sphere.colors.push_back({static_cast<uint8_t>(127.5 * (p.x + 1)), static_cast<uint8_t>(127.5 * (p.y + 1)), 90});
  }
  const Image img = *Render(sphere, o);
  absl::StatusOr<std::string> bytes = EncodePng(img);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  ASSERT_GT(bytes->size(), 33u);
  EXPECT_EQ(bytes->substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(bytes->substr(12, 4), "IHDR");
  auto be32 = [&](size_t at) {
    const auto* b = reinterpret_cast<const unsigned char*>(bytes->data() + at);
    return (uint32_t{b[0]} << 24) | (uint32_t{b[1]} << 16) | (uint32_t{b[2]} << 8) | b[3];
  };
  EXPECT_EQ(be32(16), 97u);
  EXPECT_EQ(be32(20), 61u);

  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_memory(&png, bytes->data(), bytes->size())) << png.message;
  png.format = PNG_FORMAT_RGB;
  ASSERT_EQ(png.width, 97u);
  ASSERT_EQ(png.height, 61u);
  std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(png));
  ASSERT_TRUE(png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) << png.message;
  EXPECT_EQ(pixels, img.rgb);

  const fs::path path = fs::path(::testing::TempDir()) / "render.png";
  ASSERT_TRUE(WritePng(path.string(), img).ok());
  absl::StatusOr<std::string> written = ReadFileBytes(path.string());
  ASSERT_TRUE(written.ok()) << written.status();
  EXPECT_EQ(*written, *bytes);
  fs::remove(path);
  EXPECT_EQ(WritePng("/nonexistent/dir/x.png", img).code(), absl::StatusCode::kPermissionDenied);

  Image bad = img;
  bad.rgb.pop_back();
  EXPECT_EQ(EncodePng(bad).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodePng(Image{}).status().code(), absl::StatusCode::kInvalidArgument);
}

// The largest shared mesh renders at the default size; the time is printed, not asserted
// (the machine is shared).
TEST(RenderTest, DragonRenders) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  absl::StatusOr<Mesh> dragon = ReadMesh((testing::SharedData("meshes") / "stanford-dragon.ply").string());
  ASSERT_TRUE(dragon.ok()) << dragon.status();
  const RenderOptions o;
  const auto start = std::chrono::steady_clock::now();
  absl::StatusOr<Image> img = Render(*dragon, o);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(img.ok()) << img.status();
  const int64_t covered = CoveredPixels(*img, o);
  std::printf("dragon (%d vertices, %d faces) at %dx%d: %.3f s, %lld pixels covered\n", dragon->num_vertices(),
              dragon->num_triangles(), o.width, o.height, seconds, static_cast<long long>(covered));
  // The dragon is long and thin: it fills a good part of the framed disc but not all of it.
  const double r = FramedRadiusPixels(o);
  EXPECT_GT(covered, 0.2 * kPi * r * r);
  EXPECT_LT(covered, kPi * r * r);
}

}  // namespace
}  // namespace meshsmooth
