// A scan's attributes through the OBJ and PLY readers and writers and the Draco encoder:
// per-corner texture coordinates and normals, vertex properties, OBJ material lines, and what
// the readers cannot hold named in ReadInfo::dropped.
#include <string>
#include <vector>

#include "core/attributes.h"
#include "core/io/draco_codec.h"
#include "core/io/mesh_io.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

// A unit square of two triangles (from a quad) with a seam at vertex 2, and a pyramid tip.
constexpr char kObj[] =
    "# a comment\n"
    "mtllib scan.mtl\n"
    "o scan\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1 0.2 0.4 0.6\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.25 0.75\n"
    "vn 0 0 1\nvn 0 0 -1\n"
    "usemtl skin\n"
    "f 1/1/1 2/2/1 3/3/1 4/4/1\n"
    "g top\n"
    "usemtl bark\n"
    "f 1//2 2//2 5//2\n"
    "f 2/2 3/5 5/5\n"
    "l 1 2\n"
    "cstype bspline\n";

TEST(AttributesIoTest, ObjKeepsCornerUvsNormalsAndMaterialLines) {
  ReadInfo info;
  absl::StatusOr<Mesh> m = ParseMesh(kObj, MeshFormat::kObj, &info);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(info.polygons_fanned, 1);
  EXPECT_EQ(info.dropped,
            (std::vector<std::string>{"the colours of 1 of 5 vertices (kept only when every vertex has one)",
                                      "1 OBJ 'cstype' lines", "1 OBJ line elements (l)"}));
  ASSERT_EQ(m->num_triangles(), 4);
  EXPECT_EQ(m->uvs.components, 2);
  EXPECT_EQ(m->uvs.corners, (std::vector<int32_t>{0, 1, 2, 0, 2, 3, -1, -1, -1, 1, 4, 4}));
  EXPECT_EQ(m->normals.corners, (std::vector<int32_t>{0, 0, 0, 0, 0, 0, 1, 1, 1, -1, -1, -1}));
  ASSERT_EQ(m->obj_directives.size(), 5u);
  EXPECT_EQ(m->obj_directives[0].line, "mtllib scan.mtl");
  EXPECT_EQ(m->obj_directives[3].line, "g top");
  EXPECT_EQ(m->obj_directives[3].before_triangle, 2);

  absl::StatusOr<std::string> text = SerializeMesh(*m, MeshFormat::kObj);
  ASSERT_TRUE(text.ok());
  ReadInfo again;
  absl::StatusOr<Mesh> back = ParseMesh(*text, MeshFormat::kObj, &again);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(again.dropped.empty());
  EXPECT_EQ(back->positions, m->positions);
  EXPECT_EQ(back->triangles, m->triangles);
  EXPECT_EQ(back->uvs.values, m->uvs.values);
  EXPECT_EQ(back->uvs.corners, m->uvs.corners);
  EXPECT_EQ(back->normals.corners, m->normals.corners);
  ASSERT_EQ(back->obj_directives.size(), m->obj_directives.size());
  for (size_t i = 0; i < m->obj_directives.size(); ++i) {
    EXPECT_EQ(back->obj_directives[i].line, m->obj_directives[i].line);
    EXPECT_EQ(back->obj_directives[i].before_triangle, m->obj_directives[i].before_triangle);
  }
}

constexpr char kPly[] =
    "ply\nformat ascii 1.0\n"
    "element vertex 4\n"
    "property float x\nproperty float y\nproperty float z\n"
    "property float nx\nproperty float ny\nproperty float nz\n"
    "property float s\nproperty float t\n"
    "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    "property float confidence\nproperty ushort quality\n"
    "property list uchar int neighbours\n"
    "element face 2\nproperty list uchar int vertex_indices\nproperty uchar flags\n"
    "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
    "end_header\n"
    "0 0 0 0 0 1 0 0 255 0 0 0.5 7 0\n"
    "1 0 0 0 0 1 1 0 0 255 0 0.25 8 1 0\n"
    "1 1 0 0 0 1 1 1 0 0 255 1 9 0\n"
    "0 1 0 0 0 1 0 1 9 9 9 0.125 65535 0\n"
    "3 0 1 2 1\n3 0 2 3 0\n"
    "0 1\n";

TEST(AttributesIoTest, PlyKeepsUvsNormalsColoursAndNamedProperties) {
  ReadInfo info;
  absl::StatusOr<Mesh> m = ParseMesh(kPly, MeshFormat::kPly, &info);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(info.dropped, (std::vector<std::string>{"PLY vertex list property 'neighbours'",
                                                    "PLY face property 'flags'", "1 PLY 'edge' elements"}));
  EXPECT_EQ(m->uvs.values, (std::vector<double>{0, 0, 1, 0, 1, 1, 0, 1}));
  EXPECT_EQ(m->uvs.corners, (std::vector<int32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(m->normals.entries(), 4);
  ASSERT_EQ(m->properties.size(), 2u);
  EXPECT_EQ(m->properties[0].name, "confidence");
  EXPECT_EQ(m->properties[0].values, (std::vector<double>{0.5, 0.25, 1, 0.125}));
  EXPECT_EQ(m->properties[1].type, "ushort");
  EXPECT_EQ(m->colors[3], (Rgb{9, 9, 9}));
  for (bool binary : {true, false}) {
    WriteOptions o;
    o.ply_binary = binary;
    absl::StatusOr<std::string> bytes = SerializeMesh(*m, MeshFormat::kPly, o);
    ASSERT_TRUE(bytes.ok());
    EXPECT_NE(bytes->find("property float s\nproperty float t\nproperty uchar red\nproperty uchar green\nproperty "
                          "uchar blue\nproperty float confidence\nproperty ushort quality\n"),
              std::string::npos);
    ReadInfo again;
    absl::StatusOr<Mesh> back = ParseMesh(*bytes, MeshFormat::kPly, &again);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_TRUE(again.dropped.empty());
    EXPECT_EQ(back->uvs.values, m->uvs.values);
    EXPECT_EQ(back->normals.values, m->normals.values);
    EXPECT_EQ(back->colors, m->colors);
    ASSERT_EQ(back->properties.size(), 2u);
    EXPECT_EQ(back->properties[1].values, m->properties[1].values);
  }
}

TEST(AttributesIoTest, PlyHoldsSeamsAsFaceTexcoordLists) {
  absl::StatusOr<Mesh> m = ParseMesh(kObj, MeshFormat::kObj);
  ASSERT_TRUE(m.ok());
  m->colors.clear();
  m->normals = {};
  // Fill the corners without a UV so that every corner has one.
  for (int32_t& c : m->uvs.corners) c = c < 0 ? 0 : c;
  ASSERT_FALSE(PerVertexValues(*m, m->uvs).has_value());  // vertex 2 has two UVs
  absl::StatusOr<std::string> bytes = SerializeMesh(*m, MeshFormat::kPly);
  ASSERT_TRUE(bytes.ok());
  EXPECT_NE(bytes->find("property list uchar float texcoord\n"), std::string::npos);
  absl::StatusOr<Mesh> back = ParseMesh(*bytes, MeshFormat::kPly);
  ASSERT_TRUE(back.ok()) << back.status();
  for (size_t c = 0; c < m->uvs.corners.size(); ++c) {
    for (int j = 0; j < 2; ++j) {
      EXPECT_EQ(back->uvs.values[2 * back->uvs.corners[c] + j], m->uvs.values[2 * m->uvs.corners[c] + j]);
    }
  }
}

TEST(AttributesIoTest, DracoSplitsSeamsIntoPointsAfterTheVertices) {
  absl::StatusOr<Mesh> m = ParseMesh(kObj, MeshFormat::kObj);
  ASSERT_TRUE(m.ok());
  const DracoPoints points = SplitAtSeams(*m);
  // Vertex 0: uv 0 / normal 0, then normal 1 and no uv; vertex 1 likewise, then uv 1 / no normal;
  // vertex 2: uv 2 / normal 0, then uv 4 / no normal; vertex 4: no uv / normal 1, then uv 4.
  EXPECT_EQ(points.vertex, (std::vector<int32_t>{0, 1, 2, 3, 4, 0, 1, 1, 2, 4}));
  EXPECT_EQ(points.corners, (std::vector<int32_t>{0, 1, 2, 0, 2, 3, 5, 6, 4, 7, 8, 9}));
  absl::StatusOr<std::string> bytes = EncodeDraco(*m);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  absl::StatusOr<Mesh> decoded = DecodeDraco(*bytes);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  ASSERT_EQ(decoded->num_vertices(), 10);
  for (int p = 0; p < 10; ++p) EXPECT_EQ(decoded->positions[p], m->positions[points.vertex[p]]);
  EXPECT_EQ(decoded->uvs.values[2 * 8], 0.25);  // point 8: vertex 2's second UV
}

TEST(AttributesIoTest, DracoCarriesColoursAndPropertiesBitForBit) {
  absl::StatusOr<Mesh> m = ParseMesh(kPly, MeshFormat::kPly);
  ASSERT_TRUE(m.ok());
  absl::StatusOr<std::string> bytes = EncodeDraco(*m);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  absl::StatusOr<Mesh> back = DecodeDraco(*bytes);
  ASSERT_TRUE(back.ok()) << back.status();
  // COLOR is a normalized uint8 attribute: read back as 0..1 and scaled, not taken as 0..255.
  EXPECT_EQ(back->colors, m->colors);
  ASSERT_EQ(back->properties.size(), 2u);
  EXPECT_EQ(back->properties[0].values, m->properties[0].values);
  EXPECT_EQ(back->uvs.values, m->uvs.values);
}

TEST(AttributesIoTest, ACornerOfAMissingVertexKeepsItsValueOnlyPerCorner) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}, {0, 1, 7}};
  m.uvs.components = 2;
  m.uvs.values = {0, 0, 1, 0, 0, 1, 0.5, 0.5};
  m.uvs.corners = {0, 1, 2, 0, 1, 3};
  EXPECT_FALSE(PerVertexValues(m, m.uvs).has_value());
  m.uvs.corners[5] = -1;
  EXPECT_TRUE(PerVertexValues(m, m.uvs).has_value());
}

TEST(AttributesIoTest, FreshNormalsKeepHardEdgesApart) {
  absl::StatusOr<Mesh> m = ParseMesh(kObj, MeshFormat::kObj);
  ASSERT_TRUE(m.ok());
  const CornerAttribute n = FreshNormals(*m, m->normals);
  EXPECT_EQ(n.corners, m->normals.corners);
  // Entry 0: the unit square's two faces, +z; entry 1: the face (0, 1, 4), normal (0, -1, 0.5)/|.|.
  EXPECT_EQ(n.values[0], 0.0);
  EXPECT_EQ(n.values[2], 1.0);
  EXPECT_NEAR(n.values[4], -2.0 / std::sqrt(5.0), 1e-15);
  EXPECT_NEAR(n.values[5], 1.0 / std::sqrt(5.0), 1e-15);
}

}  // namespace
}  // namespace meshsmooth
