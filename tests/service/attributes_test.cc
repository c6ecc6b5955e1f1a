// A scan's attributes through the CLI's upload and write-back (client/transfer.h) and the
// service: per-corner UVs with seams, normals, colours and vertex properties through OBJ and
// PLY (and Draco's own test files), the OBJ material lines, and everything that cannot be
// carried named.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "client/transfer.h"
#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/service/service_fixtures.h"
#include "tests/test_data.h"

namespace meshsmooth::testing {
namespace {

namespace fs = std::filesystem;

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// A noisy unit sphere with a latitude-longitude texture: the triangles across the date line
// wrap u past 1, so their corners there name a second UV entry of the same vertex (a seam);
// per-vertex normals; two materials in two groups after a mtllib line; per-vertex colours and a
// float `confidence`.
Mesh TexturedSphere() {
  Mesh m = Icosphere(4);
  const int32_t n = m.num_vertices();
  m.uvs.components = 2;
  for (const Vec3& p : m.positions) {
    m.uvs.values.push_back(0.5 + std::atan2(p.y, p.x) / (2.0 * M_PI));
    m.uvs.values.push_back(std::acos(std::fmax(-1.0, std::fmin(1.0, p.z))) / M_PI);
  }
  for (const Triangle& t : m.triangles) {
    double lo = 1.0, hi = 0.0;
    for (int32_t v : t) {
      lo = std::fmin(lo, m.uvs.values[2 * v]);
      hi = std::fmax(hi, m.uvs.values[2 * v]);
    }
    for (int32_t v : t) {
      if (hi - lo > 0.5 && m.uvs.values[2 * v] < 0.5) {  // wrapped: a second entry, u + 1
        m.uvs.corners.push_back(static_cast<int32_t>(m.uvs.values.size() / 2));
        m.uvs.values.push_back(m.uvs.values[2 * v] + 1.0);
        m.uvs.values.push_back(m.uvs.values[2 * v + 1]);
      } else {
        m.uvs.corners.push_back(v);
      }
    }
  }
  m.normals.components = 3;
  for (const Vec3& p : m.positions) m.normals.values.insert(m.normals.values.end(), {p.x, p.y, p.z});
  for (const Triangle& t : m.triangles) m.normals.corners.insert(m.normals.corners.end(), t.begin(), t.end());
  m.obj_directives = {{0, "mtllib sphere.mtl"},
                      {0, "g north"},
                      {0, "usemtl skin"},
                      {m.num_triangles() / 2, "g south"},
                      {m.num_triangles() / 2, "usemtl bark"}};
  for (int32_t v = 0; v < n; ++v) {
    m.colors.push_back({static_cast<uint8_t>(v % 251), static_cast<uint8_t>(v % 13 * 19), 200});
  }
  m.properties.push_back({"confidence", "float", {}});
  for (int32_t v = 0; v < n; ++v) m.properties.back().values.push_back(static_cast<float>(0.25 + (v % 7) / 8.0));
  AddUniformNoise(m, 0.3, 5);
  return m;
}

Mesh Stripped(const Mesh& m) {
  Mesh s;
  s.positions = m.positions;
  s.triangles = m.triangles;
  return s;
}

// The area-weighted unit normal of each vertex, computed here independently of the code tested.
std::vector<Vec3> VertexNormals(const Mesh& m) {
  std::vector<Vec3> sum(m.num_vertices());
  for (const Triangle& t : m.triangles) {
    const Vec3 fn = Cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]);
    for (int32_t v : t) sum[v] += fn;
  }
  for (Vec3& s : sum) s = Normalized(s);
  return sum;
}

class AttributesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = StartServer();
    ASSERT_NE(server_, nullptr);
    dir_ = fs::temp_directory_path() /
           ("meshsmooth_attributes_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_ / "out");
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The CLI's path for `input` -> `output` with `spec`; the result read back; what was not
  // kept to `dropped`. `with_attributes`: as the CLI uploads for a .drc output (without: for
  // any other).
  Mesh SmoothFile(const std::string& input, const std::string& output, std::vector<std::string>* dropped = nullptr,
                  const v1::JobSpec& spec = v1::JobSpec(), bool with_attributes = true) {
    absl::StatusOr<client::Upload> upload = client::PrepareUpload(input, with_attributes);
    EXPECT_TRUE(upload.ok()) << upload.status();
    if (!upload.ok()) return {};
    absl::StatusOr<SmoothOutcome> outcome = Call(server_->InProcessChannel(), spec, upload->draco);
    EXPECT_TRUE(outcome.ok()) << outcome.status();
    if (!outcome.ok()) return {};
    std::vector<std::string> lost = upload->dropped;
    const absl::Status written = client::WriteResult(*upload, outcome->result, output, false, &lost);
    EXPECT_TRUE(written.ok()) << written;
    if (dropped != nullptr) *dropped = lost;
    absl::StatusOr<Mesh> back = ReadMesh(output);
    EXPECT_TRUE(back.ok()) << back.status();
    return back.ok() ? *back : Mesh{};
  }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  // `input` smoothed into a file beside `output` with only its positions and faces uploaded:
  // the same bytes as `output` (written from the full upload), from a smaller upload.
  void ExpectSameFileWithoutAttributesSent(const std::string& input, const std::string& output) {
    const absl::StatusOr<client::Upload> full = client::PrepareUpload(Path(input), true);
    const absl::StatusOr<client::Upload> lean = client::PrepareUpload(Path(input), false);
    ASSERT_TRUE(full.ok() && lean.ok());
    EXPECT_LT(lean->draco.size(), full->draco.size());
    const std::string lean_output =
        (fs::path(output).parent_path() / ("lean-" + fs::path(output).filename().string())).string();
    std::vector<std::string> dropped;
    SmoothFile(Path(input), Path(lean_output), &dropped, v1::JobSpec(), false);
    EXPECT_TRUE(dropped.empty()) << dropped.front();
    const absl::StatusOr<std::string> want = ReadFileBytes(Path(output)), got = ReadFileBytes(Path(lean_output));
    ASSERT_TRUE(want.ok() && got.ok());
    EXPECT_TRUE(*got == *want) << lean_output << " differs from " << output;
  }

  std::unique_ptr<server::Server> server_;
  fs::path dir_;
};

// Every corner's value of `a` in `got` has the same bits as in `want`.
void ExpectSameCornerValues(const CornerAttribute& want, const CornerAttribute& got, size_t corners) {
  ASSERT_EQ(got.components, want.components);
  ASSERT_EQ(got.corners.size(), corners);
  ASSERT_EQ(want.corners.size(), corners);
  int64_t differ = 0;
  for (size_t c = 0; c < corners; ++c) {
    for (int j = 0; j < want.components; ++j) {
      differ += !SameBits(want.values[want.components * want.corners[c] + j],
                          got.values[got.components * got.corners[c] + j]);
    }
  }
  EXPECT_EQ(differ, 0);
}

// Every corner has a normal: unit, and the area-weighted normal of its vertex on `m`'s positions.
void ExpectFreshNormals(const Mesh& m) {
  ASSERT_EQ(m.normals.components, 3);
  ASSERT_EQ(m.normals.corners.size(), 3 * m.triangles.size());
  const std::vector<Vec3> want = VertexNormals(m);
  double worst_length = 0.0, worst_angle = 0.0;
  for (size_t c = 0; c < m.normals.corners.size(); ++c) {
    const int32_t e = m.normals.corners[c];
    ASSERT_GE(e, 0) << "corner " << c << " has no normal";
    const Vec3 n{m.normals.values[3 * e], m.normals.values[3 * e + 1], m.normals.values[3 * e + 2]};
    worst_length = std::fmax(worst_length, std::fabs(Norm(n) - 1.0));
    worst_angle = std::fmax(worst_angle, Norm(n - want[m.triangles[c / 3][c % 3]]));
  }
  EXPECT_LT(worst_length, 1e-6);
  EXPECT_LT(worst_angle, 1e-6);
}

TEST_F(AttributesTest, TexturedObjWithSeamsComesBackWithItsUvsGroupsAndFreshNormals) {
  Mesh in = TexturedSphere();
  in.properties.clear();  // OBJ has no place for them
  ASSERT_TRUE(WriteMesh(Path("sphere.obj"), in).ok());
  ASSERT_TRUE(WriteMesh(Path("stripped.obj"), Stripped(in)).ok());
  std::ofstream(Path("sphere.mtl")) << "newmtl skin\nmap_Kd skin.png\nnewmtl bark\nmap_Kd -bm 1 bark.png\n";
  std::ofstream(Path("skin.png")) << "not really a png";
  std::ofstream(Path("bark.png")) << "not really a png";
  const absl::StatusOr<Mesh> read = ReadMesh(Path("sphere.obj"));
  ASSERT_TRUE(read.ok());
  ASSERT_GT(read->uvs.entries(), read->num_vertices());  // the seams

  std::vector<std::string> dropped;
  const Mesh out = SmoothFile(Path("sphere.obj"), Path("out/sphere.obj"), &dropped);
  EXPECT_TRUE(dropped.empty()) << dropped.front();
  ASSERT_EQ(out.triangles, read->triangles);
  ExpectSameCornerValues(read->uvs, out.uvs, 3 * read->triangles.size());
  ExpectFreshNormals(out);
  EXPECT_EQ(out.colors, read->colors);
  ASSERT_EQ(out.obj_directives.size(), read->obj_directives.size());
  for (size_t i = 0; i < out.obj_directives.size(); ++i) {
    EXPECT_EQ(out.obj_directives[i].before_triangle, read->obj_directives[i].before_triangle);
    // Written one folder down: the material library is reached from there.
    EXPECT_EQ(out.obj_directives[i].line, i == 0 ? "mtllib ../sphere.mtl" : read->obj_directives[i].line);
  }
  EXPECT_TRUE(fs::is_regular_file(dir_ / "out" / "../sphere.mtl"));

  const Mesh bare = SmoothFile(Path("stripped.obj"), Path("out/stripped.obj"));
  ASSERT_EQ(bare.num_vertices(), out.num_vertices());
  int64_t differ = 0;
  for (int32_t v = 0; v < out.num_vertices(); ++v) {
    differ += !(SameBits(out.positions[v].x, bare.positions[v].x) &&
                SameBits(out.positions[v].y, bare.positions[v].y) && SameBits(out.positions[v].z, bare.positions[v].z));
  }
  EXPECT_EQ(differ, 0) << "vertices whose position differs from smoothing the mesh without attributes";

  // The CLI sends positions and faces only for an output other than .drc: the same file out.
  ExpectSameFileWithoutAttributesSent("sphere.obj", "out/sphere.obj");
}

TEST_F(AttributesTest, PlyWithUvsNormalsColoursAndConfidenceComesBackWhole) {
  Mesh in = TexturedSphere();
  in.obj_directives.clear();
  // One UV per vertex (a PLY `s t`): drop the seam entries.
  for (size_t c = 0; c < in.uvs.corners.size(); ++c) in.uvs.corners[c] = in.triangles[c / 3][c % 3];
  in.uvs.values.resize(2 * in.positions.size());
  for (double& x : in.uvs.values) x = static_cast<float>(x);
  for (bool binary : {true, false}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    WriteOptions o;
    o.ply_binary = binary;
    ASSERT_TRUE(WriteMesh(Path("scan.ply"), in, o).ok());
    ASSERT_TRUE(WriteMesh(Path("stripped.ply"), Stripped(in), o).ok());
    absl::StatusOr<std::string> header = ReadFileBytes(Path("scan.ply"));
    ASSERT_TRUE(header.ok());
    for (const char* p : {"property float nx\n", "property float s\nproperty float t\n", "property uchar red\n",
                          "property float confidence\n"}) {
      EXPECT_NE(header->find(p), std::string::npos) << p;
    }
    const absl::StatusOr<Mesh> read = ReadMesh(Path("scan.ply"));
    ASSERT_TRUE(read.ok());
    std::vector<std::string> dropped;
    const Mesh out = SmoothFile(Path("scan.ply"), Path("out/scan.ply"), &dropped);
    EXPECT_TRUE(dropped.empty()) << dropped.front();
    ASSERT_EQ(out.triangles, read->triangles);
    ExpectSameCornerValues(read->uvs, out.uvs, 3 * read->triangles.size());
    EXPECT_EQ(out.colors, read->colors);
    ASSERT_EQ(out.properties.size(), 1u);
    EXPECT_EQ(out.properties[0].name, "confidence");
    EXPECT_EQ(out.properties[0].type, "float");
    EXPECT_EQ(out.properties[0].values, read->properties[0].values);
    ExpectFreshNormals(out);
    const Mesh bare = SmoothFile(Path("stripped.ply"), Path("out/stripped.ply"));
    EXPECT_EQ(bare.positions, out.positions);
    ExpectSameFileWithoutAttributesSent("scan.ply", "out/scan.ply");
  }
}

TEST_F(AttributesTest, WhatCannotBeCarriedIsNamed) {
  std::ofstream(Path("parts.obj")) << "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n"
                                      "vt 0 0\nvt 1 0\nvt 1 1\n"
                                      "f 1/1 2/2 3/3 4/1\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\nl 1 3\nl 2 4\n";
  std::vector<std::string> dropped;
  v1::JobSpec spec = Spec("laplacian", 1);
  SmoothFile(Path("parts.obj"), Path("parts-out.obj"), &dropped, spec);
  EXPECT_EQ(dropped, (std::vector<std::string>{"2 OBJ line elements (l)", "1 polygons triangulated",
                                               "material library 'missing.mtl' (not found beside the input)"}));

  SmoothFile(Path("parts.obj"), Path("parts-out.off"), &dropped, spec);
  EXPECT_EQ(dropped, (std::vector<std::string>{"2 OBJ line elements (l)", "1 polygons triangulated",
                                               "1 OBJ material and group lines (.off has no place for them)",
                                               "texture coordinates (.off has no place for them)"}));

  // A material library that is there, with one texture image there and one missing: only the
  // missing image is named, and the library is linked from the output's folder.
  std::ofstream(Path("found.mtl")) << "newmtl skin\nmap_Kd skin.png\nmap_Bump -bm 0.5 bumps.png\n";
  std::ofstream(Path("skin.png")) << "not read, only looked for";
  std::ofstream(Path("found.obj")) << "mtllib found.mtl\nusemtl skin\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                                      "f 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n";
  std::filesystem::create_directories(Path("out"));
  SmoothFile(Path("found.obj"), Path("out/found.obj"), &dropped, spec);
  EXPECT_EQ(dropped, (std::vector<std::string>{"texture image 'bumps.png' of found.mtl (not found)"}));
  const absl::StatusOr<std::string> written = ReadFileBytes(Path("out/found.obj"));
  ASSERT_TRUE(written.ok());
  EXPECT_NE(written->find("\nmtllib ../found.mtl\n"), std::string::npos) << *written;

  Mesh scan = TexturedSphere();
  scan.obj_directives.clear();
  ASSERT_TRUE(WriteMesh(Path("scan.ply"), scan).ok());
  SmoothFile(Path("scan.ply"), Path("scan-out.obj"), &dropped, spec);
  EXPECT_EQ(dropped, (std::vector<std::string>{"vertex properties confidence (.obj has no place for them)"}));
}

// A face naming a vertex the file does not have cannot travel: the upload leaves it out, says
// so, and keeps the others (the server validates the rest).
TEST_F(AttributesTest, FacesNamingMissingVerticesAreLeftOutWithAWarning) {
  std::ofstream(Path("holes.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 10\nf 9 3 4\n";
  absl::StatusOr<client::Upload> upload = client::PrepareUpload(Path("holes.obj"));
  ASSERT_TRUE(upload.ok()) << upload.status();
  EXPECT_EQ(
      upload->warnings,
      (std::vector<std::string>{"2 faces reference vertices that do not exist; they cannot be sent and are left out"}));
  EXPECT_EQ(upload->kept.triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 1, 3}}));
  EXPECT_EQ(upload->num_vertices, 4);
}

// Draco's own test files with attributes, smoothed into their own format (and the .drc ones
// into OBJ): every texture coordinate comes back, normals fresh, nothing dropped.
TEST_F(AttributesTest, DracoTestFilesKeepTheirAttributes) {
  MESHSMOOTH_REQUIRE_SHARED("draco");
  const v1::JobSpec spec = Spec("laplacian", 2);
  for (const char* name : {"cube_att.obj", "cube_att.ply", "test_nm.obj"}) {
    SCOPED_TRACE(name);
    const std::string input = SharedData("draco").append(name).string();
    const absl::StatusOr<Mesh> read = ReadMesh(input);
    ASSERT_TRUE(read.ok()) << read.status();
    std::vector<std::string> dropped;
    const Mesh out = SmoothFile(input, Path(std::string("out/") + name), &dropped, spec);
    EXPECT_TRUE(dropped.empty()) << dropped.front();
    ASSERT_EQ(out.triangles, read->triangles);
    if (!read->uvs.empty()) ExpectSameCornerValues(read->uvs, out.uvs, 3 * read->triangles.size());
    EXPECT_EQ(out.normals.empty(), read->normals.empty());
    if (!read->normals.empty()) {
      // Every normal a corner names (test_nm.obj's unused vertices keep their zero normals).
      for (int32_t e : out.normals.corners) {
        ASSERT_GE(e, 0);
        const Vec3 n{out.normals.values[3 * e], out.normals.values[3 * e + 1], out.normals.values[3 * e + 2]};
        EXPECT_NEAR(Norm(n), 1.0, 1e-6);
      }
    }
  }
  for (const char* name : {"cube_att.drc", "test_nm.obj.sequential.1.1.0.drc", "test_nm.obj.edgebreaker.cl10.2.2.drc",
                           "cube_att.obj.sequential.cl3.2.2.drc"}) {
    SCOPED_TRACE(name);
    const std::string input = SharedData("draco").append(name).string();
    absl::StatusOr<std::string> bytes = ReadFileBytes(input);
    ASSERT_TRUE(bytes.ok());
    std::vector<std::string> lost;
    absl::StatusOr<Mesh> points = DecodeDraco(*bytes, &lost);
    ASSERT_TRUE(points.ok()) << points.status();
    std::vector<std::string> dropped;
    const Mesh out = SmoothFile(input, Path("out/from-drc.obj"), &dropped, spec);
    EXPECT_EQ(dropped, lost);
    ASSERT_EQ(out.triangles, points->triangles);
    EXPECT_EQ(out.uvs.empty(), points->uvs.empty());
    if (!points->uvs.empty()) {
      // OBJ text holds the decoded float32 values exactly.
      ExpectSameCornerValues(points->uvs, out.uvs, 3 * points->triangles.size());
    }
    EXPECT_EQ(out.normals.empty(), points->normals.empty());
  }
}

}  // namespace
}  // namespace meshsmooth::testing
