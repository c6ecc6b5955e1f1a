// The PLY header's property table (core/io/ply_format.h).
#include "core/io/ply_format.h"

#include <string>
#include <utility>

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

}  // namespace
}  // namespace meshsmooth
