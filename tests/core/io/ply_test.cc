// The PLY header's property table (core/io/ply_format.h) and what the reader and writer do with
// the parts of the format the round-trip tests do not reach: big-endian bodies, every scalar
// type, comments and obj_info lines, lists of any length, and integer properties written as text.
#include "core/io/ply_format.h"

#include <bit>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "core/io/mesh_io.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

using io::PlyEncoding;
using io::PlyType;

TEST(PlyTest, HeaderHoldsTheTableOfElementsAndProperties) {
  const std::string data =
      "ply\nformat binary_big_endian 1.0\ncomment made by hand\nobj_info scanner 7\n\n"
      "element vertex 4\nproperty float32 x\nproperty float y\nproperty double z\n"
      "comment between properties\nproperty uint8 quality\nproperty list uchar int neighbours\n"
      "element face 2\nproperty list ushort uint32 vertex_indices\nproperty int16 flags\n"
      "element edge 0\nend_header\nBODY";
  absl::StatusOr<io::PlyHeader> h = io::ParsePlyHeader(data);
  ASSERT_TRUE(h.ok()) << h.status();
  EXPECT_EQ(h->encoding, PlyEncoding::kBig);
  EXPECT_EQ(data.substr(h->body_offset), "BODY");
  ASSERT_EQ(h->elements.size(), 3u);
  EXPECT_EQ(h->elements[1].name, "face");
  EXPECT_EQ(h->elements[1].count, 2);
  EXPECT_EQ(h->elements[2].count, 0);

  const io::PlyElement* v = h->vertex();
  ASSERT_EQ(v, &h->elements[0]);
  EXPECT_EQ(v->count, 4);
  ASSERT_EQ(v->props.size(), 5u);
  EXPECT_EQ(v->props[0].type, PlyType::kF32);
  EXPECT_EQ(v->props[2].type, PlyType::kF64);
  EXPECT_EQ(v->FindScalar("quality"), 3);
  EXPECT_EQ(v->props[v->FindScalar("quality")].type, PlyType::kU8);
  EXPECT_EQ(v->Find("neighbours"), 4);
  EXPECT_EQ(v->FindScalar("neighbours"), -1);  // a list
  EXPECT_EQ(v->FindScalar("confidence"), -1);  // none

  const io::PlyProperty& indices = h->elements[1].props[0];
  EXPECT_TRUE(indices.is_list);
  EXPECT_EQ(indices.count_type, PlyType::kU16);
  EXPECT_EQ(indices.type, PlyType::kU32);

  h = io::ParsePlyHeader("ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n");
  ASSERT_TRUE(h.ok()) << h.status();
  EXPECT_EQ(h->vertex(), nullptr);
}

TEST(PlyTest, MalformedHeadersAreRefusedByName) {
  const std::pair<std::string, std::string> cases[] = {
      {"ply \nformat ascii 1.0\nend_header\n", "missing the 'ply' magic line"},
      {"ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format 'binary_middle_endian'"},
      {"ply\nformat ascii 1.0\nelement vertex -1\nend_header\n", "bad count for element 'vertex'"},
      {"ply\nformat ascii 1.0\nelement vertex 2147483648\nend_header\n", "bad count for element 'vertex'"},
      {"ply\nformat ascii 1.0\nelement vertex many\nend_header\n", "bad count for element 'vertex'"},
      {"ply\nformat ascii 1.0\nproperty float x\nend_header\n", "a property before any element"},
      {"ply\nformat ascii 1.0\nelement face 1\nproperty list half int vertex_indices\nend_header\n",
       "bad list count type"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty half x\nend_header\n", "unknown property type 'half'"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar int\nend_header\n",
       "a int property without a name"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperties float x\nend_header\n",
       "unexpected header line 'properties float x'"},
      {"ply\nformat ascii 1.0\nelement vertex 0\n", "incomplete header"},
      {"ply\nelement vertex 0\nend_header\n", "incomplete header"},
  };
  for (const auto& [header, expect] : cases) {
    const absl::StatusOr<io::PlyHeader> h = io::ParsePlyHeader(header);
    ASSERT_FALSE(h.ok()) << header;
    EXPECT_EQ(h.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(h.status().message().substr(0, 5 + expect.size()), "PLY: " + expect) << header;
    // The reader gives the header's error as it is.
    EXPECT_EQ(ParseMesh(header, MeshFormat::kPly).status(), h.status());
  }
}

// A PLY body as values of declared types, written in each encoding.
class Body {
 public:
  Body& Add(PlyType t, double v) {
    values_.push_back({t, v, false});
    return *this;
  }
  Body& Row() {
    values_.push_back({PlyType::kU8, 0.0, true});
    return *this;
  }
  std::string Encode(PlyEncoding enc) const {
    std::string out;
    for (const auto& [t, v, row_end] : values_) {
      if (row_end) {
        if (enc == PlyEncoding::kAscii) out += '\n';
        continue;
      }
      if (enc == PlyEncoding::kAscii) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.17g ", v);
        out += buf;
        continue;
      }
      unsigned char b[8];
      const size_t n = Store(t, v, b);
      if ((enc == PlyEncoding::kBig) == (std::endian::native == std::endian::little)) {
        for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
      }
      out.append(reinterpret_cast<const char*>(b), n);
    }
    return out;
  }

 private:
  struct Value {
    PlyType type;
    double value;
    bool row_end;  // ends a line in ASCII
  };
  template <typename T>
  static size_t Put(T value, unsigned char* b) {
    std::memcpy(b, &value, sizeof value);
    return sizeof value;
  }
  static size_t Store(PlyType t, double v, unsigned char* b) {
    switch (t) {
      case PlyType::kI8:
        return Put(static_cast<int8_t>(v), b);
      case PlyType::kU8:
        return Put(static_cast<uint8_t>(v), b);
      case PlyType::kI16:
        return Put(static_cast<int16_t>(v), b);
      case PlyType::kU16:
        return Put(static_cast<uint16_t>(v), b);
      case PlyType::kI32:
        return Put(static_cast<int32_t>(v), b);
      case PlyType::kU32:
        return Put(static_cast<uint32_t>(v), b);
      case PlyType::kF32:
        return Put(static_cast<float>(v), b);
      case PlyType::kF64:
        return Put(v, b);
    }
    return 0;
  }
  std::vector<Value> values_;
};

std::string FormatName(PlyEncoding enc) {
  return enc == PlyEncoding::kAscii    ? "ascii"
         : enc == PlyEncoding::kLittle ? "binary_little_endian"
                                       : "binary_big_endian";
}

// Every scalar type as a vertex property, a list of odd length among them, a quad and a
// pentagon, with uint16 list counts: the three encodings read to the same mesh, value for value.
TEST(PlyTest, EveryTypeReadsAlikeInAsciiAndBothByteOrders) {
  const std::string header_tail =
      " 1.0\ncomment every type\nelement vertex 5\nproperty double x\nproperty float y\nproperty short z\n"
      "property char c8\nproperty uchar u8\nproperty ushort u16\nproperty int i32\nproperty uint u32\n"
      "property list uchar float samples\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
      "obj_info after the vertices\nelement face 2\nproperty list ushort int vertex_indices\n"
      "property float area\nend_header\n";
  Body body;
  for (int v = 0; v < 5; ++v) {
    body.Add(PlyType::kF64, 0.1 * v).Add(PlyType::kF32, 0.5 * v).Add(PlyType::kI16, -300 * v);
    body.Add(PlyType::kI8, -v).Add(PlyType::kU8, 250 + v).Add(PlyType::kU16, 65535 - v);
    body.Add(PlyType::kI32, -2000000000 + v).Add(PlyType::kU32, 4000000000.0 + v);
    body.Add(PlyType::kU8, v % 3);  // 0, 1 or 2 samples
    for (int s = 0; s < v % 3; ++s) body.Add(PlyType::kF32, 9.0);
    body.Add(PlyType::kU8, 10 * v).Add(PlyType::kU8, 20 * v).Add(PlyType::kU8, 30 * v).Row();
  }
  body.Add(PlyType::kU16, 4).Add(PlyType::kI32, 0).Add(PlyType::kI32, 1).Add(PlyType::kI32, 2);
  body.Add(PlyType::kI32, 3).Add(PlyType::kF32, 1.5).Row();
  body.Add(PlyType::kU16, 5);
  for (int i : {4, 3, 2, 1, 0}) body.Add(PlyType::kI32, i);
  body.Add(PlyType::kF32, 2.5).Row();

  std::vector<Mesh> meshes;
  for (PlyEncoding enc : {PlyEncoding::kAscii, PlyEncoding::kLittle, PlyEncoding::kBig}) {
    const std::string data = "ply\nformat " + FormatName(enc) + header_tail + body.Encode(enc);
    ReadInfo info;
    absl::StatusOr<Mesh> m = ParseMesh(data, MeshFormat::kPly, &info);
    ASSERT_TRUE(m.ok()) << FormatName(enc) << ": " << m.status();
    EXPECT_EQ(info.polygons_fanned, 2) << FormatName(enc);
    EXPECT_TRUE(info.double_positions) << FormatName(enc);
    EXPECT_EQ(info.dropped,
              (std::vector<std::string>{"PLY vertex list property 'samples'", "PLY face property 'area'"}));
    meshes.push_back(*std::move(m));
  }
  const Mesh& m = meshes[0];
  ASSERT_EQ(m.positions.size(), 5u);
  EXPECT_EQ(m.positions[3], (Vec3{0.1 * 3, 1.5, -900}));
  EXPECT_EQ(m.triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}, {4, 3, 2}, {4, 2, 1}, {4, 1, 0}}));
  EXPECT_EQ(m.colors[4], (Rgb{40, 80, 120}));
  ASSERT_EQ(m.properties.size(), 5u);
  const std::pair<std::string, std::string> names[] = {
      {"c8", "char"}, {"u8", "uchar"}, {"u16", "ushort"}, {"i32", "int"}, {"u32", "uint"}};
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(m.properties[k].name, names[k].first);
    EXPECT_EQ(m.properties[k].type, names[k].second);
  }
  EXPECT_EQ(m.properties[0].values[4], -4);
  EXPECT_EQ(m.properties[1].values[4], 254);
  EXPECT_EQ(m.properties[2].values[4], 65531);
  EXPECT_EQ(m.properties[3].values[4], -1999999996);
  EXPECT_EQ(m.properties[4].values[4], 4000000004.0);
  for (size_t k = 1; k < meshes.size(); ++k) {
    EXPECT_EQ(meshes[k].positions, m.positions) << k;
    EXPECT_EQ(meshes[k].triangles, m.triangles) << k;
    EXPECT_EQ(meshes[k].colors, m.colors) << k;
    for (size_t p = 0; p < m.properties.size(); ++p) {
      EXPECT_EQ(meshes[k].properties[p].values, m.properties[p].values) << k << " " << m.properties[p].name;
    }
  }
}

// A face's list: fewer than 3 corners, a length past 10^6 and indices that are not whole
// numbers; a texcoord list that does not hold a u, v per corner gives those corners none.
TEST(PlyTest, FaceListsOfOddLengths) {
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar float vertex_indices\nproperty list uchar float texcoord\nend_header\n"
      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
  absl::StatusOr<Mesh> m = ParseMesh(head + "4 0 1 2 3 8 0 0 1 0 1 1 0 1\n3 0 2.5 -7 5 0 0 1 0 1\n", MeshFormat::kPly);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}, {0, -1, -1}}));
  EXPECT_EQ(m->uvs.corners, (std::vector<int32_t>{0, 1, 2, 3, 4, 5, -1, -1, -1}));
  EXPECT_EQ(m->uvs.values, (std::vector<double>{0, 0, 1, 0, 1, 1, 0, 0, 1, 1, 0, 1}));

  m = ParseMesh(head + "4 0 1 2 3 0\n2 0 1 0\n", MeshFormat::kPly);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().message(), "PLY: face 1 has fewer than 3 vertices");
  const std::string wide =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list int int vertex_indices\nend_header\n0 0 0\n1000001 0 0 0\n";
  m = ParseMesh(wide, MeshFormat::kPly);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().message(), "PLY: bad list length in element 'face' 0");
  m = ParseMesh(head + "4 0 1 2\n", MeshFormat::kPly);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().message(), "PLY: data ends inside element 'face' 0");
}

// Integer vertex properties are rounded and clamped to their type, in text as in binary.
TEST(PlyTest, IntegerPropertiesAreRoundedAndClampedAlikeInTextAndBinary) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  m.properties = {{"c", "char", {-200, 2.5, -2.5, 127}},
                  {"w", "ushort", {-1, 70000, 1.4999, 65535}},
                  {"n", "uint", {5e9, -3, 1e300, 0}}};
  const std::vector<std::vector<double>> expect = {
      {-128, 3, -3, 127}, {0, 65535, 1, 65535}, {4294967295.0, 0, 4294967295.0, 0}};
  for (bool binary : {false, true}) {
    WriteOptions o;
    o.ply_binary = binary;
    absl::StatusOr<std::string> bytes = SerializeMesh(m, MeshFormat::kPly, o);
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    EXPECT_NE(bytes->find("property char c\nproperty ushort w\nproperty uint n\n"), std::string::npos);
    absl::StatusOr<Mesh> back = ParseMesh(*bytes, MeshFormat::kPly);
    ASSERT_TRUE(back.ok()) << back.status();
    ASSERT_EQ(back->properties.size(), 3u);
    for (size_t k = 0; k < 3; ++k) EXPECT_EQ(back->properties[k].values, expect[k]) << binary << " " << k;
  }
}

}  // namespace
}  // namespace meshsmooth
