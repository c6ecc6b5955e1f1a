#include "core/io/mesh_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "gtest/gtest.h"
#include "tests/test_data.h"

namespace meshsmooth {
namespace {

namespace fs = std::filesystem;

// A mesh with awkward values (no short decimal form, tiny and large magnitudes, negative zero)
// and faces that OpenMesh would refuse (repeated index) or split (non-manifold edge).
Mesh AwkwardMesh() {
  Mesh m = Icosphere(2);
  AddUniformNoise(m, 0.3, 7);
  for (Vec3& p : m.positions) {  // float values, as every binary path stores float32
    p = RoundToFloat({p.x * 1e-3, p.y * 1e5, p.z});
  }
  m.positions[3] = RoundToFloat({-0.0, 1.0 / 3.0, 7e-30});
  m.positions.push_back({9, 9, 9});   // an unreferenced vertex at the end
  m.triangles.push_back({5, 5, 6});   // repeated index: kept, not used by the topology
  m.triangles.push_back({0, 11, 1});  // a third face on an existing edge (non-manifold)
  return m;
}

class RoundTripTest : public ::testing::TestWithParam<std::string> {};

TEST_P(RoundTripTest, KeepsCountsOrderAndFloatValues) {
  const Mesh m = AwkwardMesh();
  const fs::path path = fs::path(::testing::TempDir()) / ("roundtrip." + GetParam());
  WriteOptions options;
  options.ply_binary = GetParam() != "ascii.ply";
  ASSERT_TRUE(WriteMesh(path.string(), m, options).ok());
  absl::StatusOr<Mesh> back = ReadMesh(path.string());
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->positions.size(), m.positions.size());
  ASSERT_EQ(back->triangles, m.triangles);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    ASSERT_EQ(back->positions[i], m.positions[i]) << "vertex " << i;
  }
  fs::remove(path);
}

INSTANTIATE_TEST_SUITE_P(Formats, RoundTripTest, ::testing::Values("obj", "ply", "ascii.ply", "off", "drc"),
                         [](const auto& param_info) {
                           std::string s = param_info.param;
                           std::replace(s.begin(), s.end(), '.', '_');
                           return s;
                         });

TEST(IoTest, TextFormatsRoundTripDoublesExactly) {
  Mesh m = Icosphere(1);
  AddUniformNoise(m, 0.3, 3);
  m.positions[0] = {0.1, 1.0 / 3.0, -2.5e-300};
  for (const char* ext : {"obj", "off"}) {
    absl::StatusOr<std::string> bytes = SerializeMesh(m, *FormatFromPath(std::string("x.") + ext));
    ASSERT_TRUE(bytes.ok());
    absl::StatusOr<Mesh> back = ParseMesh(*bytes, *FormatFromPath(std::string("x.") + ext));
    ASSERT_TRUE(back.ok()) << back.status();
    for (size_t i = 0; i < m.positions.size(); ++i) ASSERT_EQ(back->positions[i], m.positions[i]) << ext;
  }
}

TEST(IoTest, StlWeldsCornersAndKeepsFaces) {
  Mesh m = Icosphere(2);
  for (Vec3& p : m.positions) p = RoundToFloat(p);
  const fs::path path = fs::path(::testing::TempDir()) / "sphere.stl";
  ASSERT_TRUE(WriteMesh(path.string(), m).ok());
  ReadInfo info;
  absl::StatusOr<Mesh> back = ReadMesh(path.string(), &info);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->positions.size(), m.positions.size());
  ASSERT_EQ(back->triangles.size(), m.triangles.size());
  EXPECT_EQ(info.welded_corners, 3 * static_cast<int64_t>(m.triangles.size()) - m.num_vertices());
  // Same geometry face by face (STL renumbers vertices in order of first appearance).
  for (size_t f = 0; f < m.triangles.size(); ++f) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_EQ(back->positions[back->triangles[f][c]], m.positions[m.triangles[f][c]]);
    }
  }
  EXPECT_TRUE(Validate(*back).closed());
  fs::remove(path);
}

// A binary STL whose header declares 715,827,883 facets: 2^31 + 1 corners, more than
// WeldPoints can number. The file (35.8 GB, its size matching the count) is sparse and mapped,
// so nothing but its header is ever read; the reader must refuse it by the count, before it
// reserves or reads a corner (51 GB of them).
TEST(IoTest, StlWithMoreCornersThanWeldingIndexesIsRefused) {
  constexpr uint32_t kFacets = 715'827'883;
  const uint64_t size = 84 + 50 * uint64_t{kFacets};
  const fs::path path = fs::path(::testing::TempDir()) / "huge.stl";
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC, 0600);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::ftruncate(fd, static_cast<off_t>(size)), 0);
  ASSERT_EQ(::pwrite(fd, &kFacets, sizeof kFacets, 80), static_cast<ssize_t>(sizeof kFacets));
  void* map = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, fd, 0);
  ::close(fd);
  fs::remove(path);  // the mapping keeps the file until it is unmapped
  ASSERT_NE(map, MAP_FAILED);
  const absl::StatusOr<Mesh> m = ParseMesh(std::string_view(static_cast<const char*>(map), size), MeshFormat::kStl);
  ::munmap(map, size);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(m.status().message().find("715827883 facets have 2147483649 corners"), std::string::npos) << m.status();
  EXPECT_NE(m.status().message().find("at most 2147483647"), std::string::npos) << m.status();
}

TEST(IoTest, ObjPolygonsAreFannedAndNegativeIndicesResolved) {
  const std::string obj =
      "# quad and a relative triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\n"
      "f 1/1 2/1 3/1 4/1\nf -4 -3 -1\n";
  ReadInfo info;
  absl::StatusOr<Mesh> m = ParseMesh(obj, MeshFormat::kObj, &info);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(info.polygons_fanned, 1);
  ASSERT_EQ(m->triangles.size(), 3u);
  EXPECT_EQ(m->triangles[0], (Triangle{0, 1, 2}));
  EXPECT_EQ(m->triangles[1], (Triangle{0, 2, 3}));
  EXPECT_EQ(m->triangles[2], (Triangle{0, 1, 3}));
}

TEST(IoTest, MalformedFilesGiveClearErrors) {
  struct Case {
    MeshFormat format;
    std::string data, expect;
  };
  const Case cases[] = {
      {MeshFormat::kObj, "v 1 2\n", "line 1"},
      {MeshFormat::kObj, "v 0 0 0\nf 1 x 1\n", "bad face index"},
      {MeshFormat::kPly, "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n", "x, y, z"},
      {MeshFormat::kPly,
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\nab",
       "exceeds the file size"},
      {MeshFormat::kPly, "plx\n", "magic"},
      {MeshFormat::kOff, "OFF\n3 1 0\n0 0 0\n1 0 0\n", "expected 3 vertices"},
      {MeshFormat::kStl, "garbage", "neither binary"},
      {MeshFormat::kStl, "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n",
       "facet 0 has 2 vertices"},
      {MeshFormat::kStl, "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n",
       "facet 0 has no 'endloop'"},
      {MeshFormat::kDraco, "DRACO garbage", "Draco"},
  };
  for (const Case& c : cases) {
    absl::StatusOr<Mesh> m = ParseMesh(c.data, c.format);
    ASSERT_FALSE(m.ok()) << c.data;
    EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(m.status().message().find(c.expect), std::string::npos) << m.status();
  }
  EXPECT_EQ(ReadMesh("/nonexistent/file.obj").status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(ReadMesh("mesh.xyz").status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(IoTest, TruncatedFilesNeverCrash) {
  Mesh m = Icosphere(1);
  m.colors.assign(m.positions.size(), Rgb{10, 20, 30});  // PLY's colour path too
  for (MeshFormat f : {MeshFormat::kObj, MeshFormat::kPly, MeshFormat::kOff, MeshFormat::kStl}) {
    const std::string full = *SerializeMesh(m, f);
    for (size_t len = 0; len < full.size(); len += 7) {
      absl::StatusOr<Mesh> part = ParseMesh(std::string_view(full).substr(0, len), f);
      if (!part.ok()) continue;
      Validate(*part);  // whatever was read must be safe to validate
      EXPECT_TRUE(part->colors.empty() || part->colors.size() == part->positions.size());
    }
  }
}

// A second vertex element would replace the positions but leave the first one's colours, one
// per vertex of another count: refused (a fuzz_ply input).
TEST(IoTest, PlyWithTwoVertexElementsIsRefused) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
      "0 0 0 1 2 3\n1 0 0 4 5 6\n7 8 9\n";
  absl::StatusOr<Mesh> m = ParseMesh(ply, MeshFormat::kPly);
  ASSERT_FALSE(m.ok()) << m->positions.size() << " positions, " << m->colors.size() << " colours";
  EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(m.status().message().find("more than one vertex element"), std::string::npos) << m.status();
}

// A property line without a name ("property uint32 "): refused, where it was read as a vertex
// property named "" that a .drc output then carried as a metadata entry Draco's decoder refuses
// (a fuzz_ply input).
TEST(IoTest, PlyPropertyWithoutANameIsRefused) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property uint32 \nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0 1\n1 0 0 2\n0 1 0 3\n3 0 1 2\n";
  absl::StatusOr<Mesh> m = ParseMesh(ply, MeshFormat::kPly);
  ASSERT_FALSE(m.ok()) << m->properties.size() << " properties";
  EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(m.status().message().find("property without a name"), std::string::npos) << m.status();
}

TEST(IoTest, PlyColoursRoundTripInAsciiAndBinary) {
  Mesh m = Icosphere(2);
  for (Vec3& p : m.positions) p = RoundToFloat(p);
  for (int32_t i = 0; i < m.num_vertices(); ++i) {
    m.colors.push_back({static_cast<uint8_t>(i), static_cast<uint8_t>(255 - i % 256), static_cast<uint8_t>(i * 7)});
  }
  for (bool binary : {false, true}) {
    WriteOptions options;
    options.ply_binary = binary;
    absl::StatusOr<std::string> bytes = SerializeMesh(m, MeshFormat::kPly, options);
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    EXPECT_NE(bytes->find("property uchar red\nproperty uchar green\nproperty uchar blue\n"), std::string::npos);
    absl::StatusOr<Mesh> back = ParseMesh(*bytes, MeshFormat::kPly);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(back->positions, m.positions) << "binary " << binary;
    EXPECT_EQ(back->triangles, m.triangles) << "binary " << binary;
    EXPECT_EQ(back->colors, m.colors) << "binary " << binary;
  }
  // Without colours nothing colour-related is written and none is read back.
  m.colors.clear();
  const std::string plain = *SerializeMesh(m, MeshFormat::kPly);
  EXPECT_EQ(plain.find("red"), std::string::npos);
  EXPECT_TRUE(ParseMesh(plain, MeshFormat::kPly)->colors.empty());
}

TEST(IoTest, PlyColoursAmongOtherProperties) {
  // Colours in the middle of other vertex properties (normals, alpha, a float quality), a face
  // element with an extra property, and an extra element: the colours are found by name.
  const std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nproperty uchar alpha\nproperty float quality\n"
      "element face 1\nproperty list uchar int vertex_indices\nproperty uchar flags\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
      "0 0 0 0 0 1 255 0 0 128 0.5\n1 0 0 0 0 1 0 255 0 128 0.5\n0 1 0 0 0 1 10 20 30 128 0.5\n"
      "3 0 1 2 7\n0 1\n";
  absl::StatusOr<Mesh> m = ParseMesh(ascii, MeshFormat::kPly);
  ASSERT_TRUE(m.ok()) << m.status();
  ASSERT_EQ(m->positions.size(), 3u);
  EXPECT_EQ(m->positions[1], (Vec3{1, 0, 0}));
  EXPECT_EQ(m->triangles, (std::vector<Triangle>{{0, 1, 2}}));
  EXPECT_EQ(m->colors, (std::vector<Rgb>{{255, 0, 0}, {0, 255, 0}, {10, 20, 30}}));

  // The same in binary, with the colour before the position and a double property between.
  std::string bin =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nproperty double confidence\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 0\nproperty list uchar int vertex_indices\nend_header\n";
  for (int v = 0; v < 2; ++v) {
    const unsigned char rgb[3] = {static_cast<unsigned char>(200 + v), 100, 50};
    bin.append(reinterpret_cast<const char*>(rgb), 3);
    const double confidence = 0.25;
    bin.append(reinterpret_cast<const char*>(&confidence), sizeof confidence);
    const float xyz[3] = {static_cast<float>(v), 2, 3};
    bin.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
  }
  m = ParseMesh(bin, MeshFormat::kPly);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->positions, (std::vector<Vec3>{{0, 2, 3}, {1, 2, 3}}));
  EXPECT_EQ(m->colors, (std::vector<Rgb>{{200, 100, 50}, {201, 100, 50}}));
}

TEST(IoTest, ColoursOfTheWrongCountAreRefusedForPlyAndIgnoredElsewhere) {
  Mesh m = Icosphere(1);
  m.colors.assign(m.positions.size() - 1, Rgb{1, 2, 3});
  for (bool binary : {false, true}) {
    WriteOptions options;
    options.ply_binary = binary;
    absl::StatusOr<std::string> bytes = SerializeMesh(m, MeshFormat::kPly, options);
    ASSERT_FALSE(bytes.ok());
    EXPECT_EQ(bytes.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(bytes.status().message().find("colours"), std::string::npos) << bytes.status();
  }
  EXPECT_EQ(WriteMesh((fs::path(::testing::TempDir()) / "bad-colours.ply").string(), m).code(),
            absl::StatusCode::kInvalidArgument);
  // Formats without colours write the geometry and drop them, whatever their count.
  for (MeshFormat f : {MeshFormat::kObj, MeshFormat::kOff, MeshFormat::kStl, MeshFormat::kDraco}) {
    absl::StatusOr<std::string> bytes = SerializeMesh(m, f);
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    absl::StatusOr<Mesh> back = ParseMesh(*bytes, f);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_TRUE(back->colors.empty());
  }
}

using OMesh = OpenMesh::TriMesh_ArrayKernelT<>;

// For a clean manifold mesh OpenMesh's reader and ours must agree vertex for vertex.
TEST(IoTest, AgreesWithOpenMeshOnCleanMeshes) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  for (const char* file : {"fandisk.obj", "bunny-small.obj"}) {
    const std::string path = (testing::SharedData("meshes") / file).string();
    absl::StatusOr<Mesh> ours = ReadMesh(path);
    ASSERT_TRUE(ours.ok());
    OMesh om;
    omerr().disable();
    ASSERT_TRUE(OpenMesh::IO::read_mesh(om, path));
    ASSERT_EQ(om.n_vertices(), ours->positions.size()) << file;
    ASSERT_EQ(om.n_faces(), ours->triangles.size()) << file;
    for (auto vh : om.vertices()) {
      const auto& p = om.point(vh);
      const Vec3& q = ours->positions[vh.idx()];
      ASSERT_FLOAT_EQ(p[0], static_cast<float>(q.x));
      ASSERT_FLOAT_EQ(p[1], static_cast<float>(q.y));
      ASSERT_FLOAT_EQ(p[2], static_cast<float>(q.z));
    }
    for (auto fh : om.faces()) {
      std::array<int32_t, 3> t{};
      int k = 0;
      for (auto vh : om.fv_range(fh)) t[k++] = vh.idx();
      ASSERT_EQ(t, ours->triangles[fh.idx()]);
    }
  }
}

// The non-manifold beetle and the dragon with zero-area faces: every vertex and every face of
// the file, index for index (OpenMesh's readers change both counts).
TEST(IoTest, DirtyMeshesAreReadIndexForIndex) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  struct Expect {
    const char* file;
    size_t vertices, faces;
  };
  for (const Expect& e : {Expect{"beetle.obj", 1148, 2053}, Expect{"stanford-dragon.ply", 437645, 871414}}) {
    const std::string path = (testing::SharedData("meshes") / e.file).string();
    absl::StatusOr<Mesh> m = ReadMesh(path);
    ASSERT_TRUE(m.ok()) << m.status();
    EXPECT_EQ(m->positions.size(), e.vertices);
    EXPECT_EQ(m->triangles.size(), e.faces);
    // Writing in the same format and reading back keeps every index and value.
    const fs::path out =
        fs::path(::testing::TempDir()) / (std::string("dirty") + fs::path(e.file).extension().string());
    ASSERT_TRUE(WriteMesh(out.string(), *m).ok());
    absl::StatusOr<Mesh> back = ReadMesh(out.string());
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(back->triangles, m->triangles);
    EXPECT_EQ(back->positions, m->positions);
    fs::remove(out);
  }
  // First face of the beetle as written in the file (1-based there).
  std::ifstream in(testing::SharedData("meshes") / "beetle.obj");
  std::string line;
  while (std::getline(in, line) && line.rfind("f ", 0) != 0) {
  }
  int a, b, c;
  ASSERT_EQ(std::sscanf(line.c_str(), "f %d %d %d", &a, &b, &c), 3);
  const Mesh beetle = *ReadMesh((testing::SharedData("meshes") / "beetle.obj").string());
  EXPECT_EQ(beetle.triangles[0], (Triangle{a - 1, b - 1, c - 1}));
}

TEST(IoTest, SharedStlFilesLoad) {
  MESHSMOOTH_REQUIRE_SHARED("draco");
  for (const char* file : {"bunny.stl", "test_sphere.stl", "test_sphere_ascii.stl"}) {
    absl::StatusOr<Mesh> m = ReadMesh((testing::SharedData("draco") / file).string());
    ASSERT_TRUE(m.ok()) << file << ": " << m.status();
    EXPECT_GT(m->triangles.size(), 100u) << file;
    const ValidationReport r = Validate(*m);
    EXPECT_EQ(r.dropped_faces(), 0) << file;
    EXPECT_GT(r.edges, 0) << file;
  }
  // The binary and ASCII spheres are the same mesh.
  const Mesh bin = *ReadMesh((testing::SharedData("draco") / "test_sphere.stl").string());
  const Mesh asc = *ReadMesh((testing::SharedData("draco") / "test_sphere_ascii.stl").string());
  EXPECT_EQ(bin.triangles, asc.triangles);
  EXPECT_EQ(bin.positions.size(), asc.positions.size());
}

}  // namespace
}  // namespace meshsmooth
