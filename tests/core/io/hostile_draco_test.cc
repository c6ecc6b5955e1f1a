// Hostile Draco uploads: face indices past the point count, a second POSITION
// attribute, extreme or non-finite coordinates, and output encodings whose cost or result
// would be unbounded. Each is refused with INVALID_ARGUMENT (sizes beyond the vertex limit with
// RESOURCE_EXHAUSTED) before anything indexes, allocates or encodes with it, and every encoding
// that is accepted decodes to the welded input's vertices.
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <tuple>

#include "core/io/draco_codec.h"
#include "core/io/mesh_io.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "draco/compression/decode.h"
#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"
#include "draco/metadata/geometry_metadata.h"
#include "gtest/gtest.h"
#include "tests/hostile_inputs.h"

namespace meshsmooth {
namespace {

using testing::EdgebreakerHead;
using testing::RawDraco;
using testing::TorusWithIndexPastThePoints;

void ExpectInvalid(const absl::Status& s, const std::string& words) {
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_NE(s.message().find(words), std::string::npos) << s;
}

// Draco's own decoder accepts such a face; ours refuses it on every decoding path, before the
// weld, the topology or an encoder could index with it.
TEST(HostileDracoTest, FaceIndexPastThePointsIsRefused) {
  const std::string bytes = RawDraco(TorusWithIndexPastThePoints());
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  ASSERT_TRUE(decoder.DecodeMeshFromBuffer(&buffer).ok()) << "Draco itself no longer accepts the case";

  const std::string words = "face 5 refers to point 65535, but the mesh has 1160 points";
  ExpectInvalid(DecodeDraco(bytes).status(), words);
  ExpectInvalid(DracoMesh::Decode(bytes).status(), words);
  ExpectInvalid(DecodeDracoAttribute(bytes, "kmax").status(), words);
}

// A second POSITION attribute crashes Draco's Edgebreaker encoder: refused at decode.
TEST(HostileDracoTest, SecondPositionAttributeIsRefused) {
  const std::string bytes = RawDraco(TwoRateTorus(20), /*positions=*/2);
  ExpectInvalid(DracoMesh::Decode(bytes).status(), "2 POSITION attributes");
  ExpectInvalid(DecodeDraco(bytes).status(), "2 POSITION attributes");
}

// Every per-point check and copy is linear in the number of attributes, and a Draco file can
// declare thousands of constant ones in a few bytes each: more than 256 are refused.
TEST(HostileDracoTest, MoreThan256AttributesAreRefused) {
  const Mesh m = Icosphere(0);
  for (int count : {256, 257}) {
    draco::Mesh dm;
    dm.set_num_points(m.num_vertices());
    draco::GeometryAttribute ga;
    ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
    const int pos = dm.AddAttribute(ga, /*identity_mapping=*/true, m.num_vertices());
    for (int32_t i = 0; i < m.num_vertices(); ++i) {
      const float v[3] = {static_cast<float>(m.positions[i].x), static_cast<float>(m.positions[i].y),
                          static_cast<float>(m.positions[i].z)};
      dm.attribute(pos)->SetAttributeValue(draco::AttributeValueIndex(i), v);
    }
    for (int k = 1; k < count; ++k) {
      draco::GeometryAttribute g;
      g.Init(draco::GeometryAttribute::GENERIC, nullptr, 1, draco::DT_UINT8, false, 1, 0);
      const int id = dm.AddAttribute(g, /*identity_mapping=*/true, m.num_vertices());
      for (int32_t i = 0; i < m.num_vertices(); ++i) {
        const uint8_t value = static_cast<uint8_t>(k);
        dm.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(i), &value);
      }
    }
    for (const Triangle& t : m.triangles) {
      dm.AddFace({draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
    }
    draco::Encoder encoder;
    encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
    draco::EncoderBuffer buf;
    ASSERT_TRUE(encoder.EncodeMeshToBuffer(dm, &buf).ok());
    const absl::Status s = DracoMesh::Decode(std::string_view(buf.data(), buf.size())).status();
    if (count == 256) {
      EXPECT_TRUE(s.ok()) << s;
    } else {
      ExpectInvalid(s, "the Draco mesh has 257 attributes; at most 256");
    }
  }
}

// A raw Draco file (a fuzz_job input) whose POSITION attribute says DT_BOOL, with a byte of 49
// for a value. Reading it as a number loads a bool that is neither 0 nor 1 (undefined; UBSan
// stops there). Positions and named attributes must be of an integer or floating-point type.
TEST(HostileDracoTest, PositionsOfTypeBoolAreRefused) {
  const std::string bytes(
      "\x44\x52\x41\x43\x4f\x02\x02\x01\x00\x00\x00\x06\x06\x01\x00\x02\x01\x00\x01\x03\x01\x02\x03\x00"
      "\x03\x02\x00\x01\x04\x02\x02\x03\x01\x01\x00\x0b\x03\x00\x00\x00\x00\x31\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x3f"
      "\x00\x00\x00\x00\x3f\x00\x00\x00\x00\x50\x96\x06\x3f\x40\xc4\x59\x3f\x7a\x37\x9e\x3a\x20\x76\x61"
      "\x6c\x75\x65\x20\x69\x73\x20\x6e\x6f\x74\x20\x64\x65\x66\x69\x6e\x65\x64\x3e\xbd\x1b\x4f\x3f\x00"
      "\x00\x00\x3f\x50\x96\x06\x3f\x00\xa0\x40\x00\x00\xa0\x40",
      134);
  ExpectInvalid(DecodeDraco(bytes).status(), "POSITION attribute holds booleans");
  ExpectInvalid(DracoMesh::Decode(bytes).status(), "POSITION attribute holds booleans");

  // A named attribute of booleans, as DecodeDracoAttribute reads result attributes.
  const Mesh m = Icosphere(0);
  draco::DecoderBuffer buffer;
  const std::string plain = RawDraco(m);
  buffer.Init(plain.data(), plain.size());
  std::unique_ptr<draco::Mesh> dm = draco::Decoder().DecodeMeshFromBuffer(&buffer).value();
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::GENERIC, nullptr, 1, draco::DT_BOOL, false, 1, 0);
  const int id = dm->AddAttribute(ga, /*identity_mapping=*/true, dm->num_points());
  for (uint32_t p = 0; p < dm->num_points(); ++p) {
    const bool value = p % 2 == 0;
    dm->attribute(id)->SetAttributeValue(draco::AttributeValueIndex(p), &value);
  }
  auto metadata = std::make_unique<draco::AttributeMetadata>();
  metadata->AddEntryString("name", "kmax");
  dm->AddAttributeMetadata(id, std::move(metadata));
  draco::Encoder encoder;
  encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
  draco::EncoderBuffer out;
  ASSERT_TRUE(encoder.EncodeMeshToBuffer(*dm, &out).ok());
  ExpectInvalid(DecodeDracoAttribute(std::string(out.data(), out.size()), "kmax").status(),
                "attribute 'kmax' holds booleans");
}

// Coordinates must be finite and at most kMaxCoordinate in magnitude: 3.4e38 makes Draco's
// quantizer overflow (a SIGSEGV in its entropy estimate), and NaN has no grid cell.
TEST(HostileDracoTest, ExtremeAndNonFiniteCoordinatesAreRefused) {
  Mesh m = TwoRateTorus(20);
  m.positions[7].x = 3.4e38;
  ExpectInvalid(DracoMesh::Decode(RawDraco(m)).status(), "point 7 has a coordinate of 3.4e+38");
  m.positions[7].x = -kMaxCoordinate;  // the limit itself is fine
  EXPECT_TRUE(DracoMesh::Decode(RawDraco(m)).ok());
  m.positions[9].z = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalid(DecodeDraco(RawDraco(m)).status(), "point 9 has a coordinate of nan");
  m.positions[9].z = -std::numeric_limits<double>::infinity();
  ExpectInvalid(DecodeDraco(RawDraco(m)).status(), "point 9 has a coordinate of -inf");

  // Our own encoders write no such coordinate either.
  ExpectInvalid(EncodeDraco(m).status(), "vertex 9 has a coordinate of -inf");
  m.positions[9].z = 0.0;
  absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(RawDraco(m));
  ASSERT_TRUE(dm.ok()) << dm.status();
  Mesh welded = dm->TakeWelded();
  welded.positions[3].y = 1e31;
  DracoOptions quantized;
  quantized.quantization_bits = 22;
  ExpectInvalid(dm->Encode(welded, quantized).status(), "vertex 3 has a coordinate of 1e+31");
}

// Quantization costs ~2^(bits + 2) bytes in Draco's encoder whatever the mesh (3.7 GB at 30
// bits): above kMaxQuantizationBits, which is already finer than float32 over the box, the
// options are refused.
TEST(HostileDracoTest, QuantizationAboveTheCapIsRefused) {
  const Mesh m = Icosphere(1);
  DracoOptions o;
  o.quantization_bits = kMaxQuantizationBits;
  EXPECT_TRUE(EncodeDraco(m, o).ok());
  for (int bits : {kMaxQuantizationBits + 1, 27, 30}) {
    o.quantization_bits = bits;
    ExpectInvalid(EncodeDraco(m, o).status(), "quantization bits must be 0 (lossless) or 1..24");
  }
}

// Edgebreaker drops vertices that no face with three distinct points uses: refused, so that
// no result has fewer vertices than the upload.
TEST(HostileDracoTest, EdgebreakerThatWouldDropAVertexIsRefused) {
  Mesh m = Icosphere(1);
  m.positions.push_back({3, 3, 3});  // isolated
  DracoOptions eb;
  eb.method = DracoMethod::kEdgebreaker;
  ExpectInvalid(EncodeDraco(m, eb).status(), "Edgebreaker would drop 1 vertex");
  absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(*EncodeDraco(m));
  ASSERT_TRUE(dm.ok()) << dm.status();
  ExpectInvalid(dm->CheckEncodable(eb), "Edgebreaker would drop 1 vertex");
  ExpectInvalid(dm->Encode(dm->welded(), eb).status(), "Edgebreaker would drop 1 vertex");
  EXPECT_TRUE(dm->CheckEncodable({}).ok());

  // A vertex used only by a face with a repeated index is dropped too; a seam copy of a vertex
  // (same position, another point) is not: the vertex survives through its other point.
  Mesh d = Icosphere(1);
  const int32_t n = d.num_vertices();
  d.positions.push_back({3, 3, 3});
  d.triangles.push_back({0, n, n});
  ExpectInvalid(EncodeDraco(d, eb).status(), "Edgebreaker would drop 1 vertex");
  Mesh seam = Icosphere(1);
  seam.positions.push_back(seam.positions[4]);
  seam.triangles.push_back({4, n, 2});
  absl::StatusOr<DracoMesh> sm = DracoMesh::Decode(*EncodeDraco(seam));
  ASSERT_TRUE(sm.ok()) << sm.status();
  EXPECT_TRUE(sm->CheckEncodable(eb).ok());
}

// Draco's Edgebreaker decoder allocates its corner table from the declared counts before it
// reads a symbol (a fuzz_job input: 1.4 KB declaring 235 million faces takes 2.8 GB); the counts
// are checked against the vertex limit first.
TEST(HostileDracoTest, EdgebreakerSizesBeyondTheVertexLimitAreRefusedBeforeDecoding) {
  constexpr int64_t kLimit = 1 << 20;
  for (bool v22 : {false, true}) {
    SCOPED_TRACE(v22 ? "bitstream 2.2" : "bitstream 1.2");
    const absl::Status faces = DracoMesh::Decode(EdgebreakerHead(v22, 1000, 235'472'908), {}, kLimit).status();
    EXPECT_EQ(faces.code(), absl::StatusCode::kResourceExhausted) << faces;
    EXPECT_NE(faces.message().find("declares 235472908 faces"), std::string::npos) << faces;
    EXPECT_NE(faces.message().find("at most 4194304 faces"), std::string::npos) << faces;
    const absl::Status vertices = DracoMesh::Decode(EdgebreakerHead(v22, 3'000'000, 1'500'000), {}, kLimit).status();
    EXPECT_EQ(vertices.code(), absl::StatusCode::kResourceExhausted) << vertices;
    EXPECT_NE(vertices.message().find(v22 ? "3000000 vertices" : "3000002 vertices"), std::string::npos) << vertices;
    // Within the limit the counts pass, and Draco's decoder refuses the garbage after them.
    const absl::Status small = DracoMesh::Decode(EdgebreakerHead(v22, 1000, 2000), {}, kLimit).status();
    EXPECT_EQ(small.code(), absl::StatusCode::kInvalidArgument) << small;
  }
  // A real Edgebreaker mesh (162 vertices, 320 faces; it declares 163 vertices, its one split
  // symbol counted): at its own vertex count as the limit it decodes, and so it does down to a
  // limit of 82 (2 * 82 >= 163); at 81 it is refused.
  DracoOptions eb;
  eb.method = DracoMethod::kEdgebreaker;
  const Mesh sphere = Icosphere(2);
  const std::string bytes = *EncodeDraco(sphere, eb);
  for (int64_t limit : {int64_t{sphere.num_vertices()}, int64_t{82}}) {
    const absl::Status s = DracoMesh::Decode(bytes, {}, limit).status();
    EXPECT_TRUE(s.ok()) << limit << ": " << s;
  }
  const absl::Status tight = DracoMesh::Decode(bytes, {}, 81).status();
  EXPECT_EQ(tight.code(), absl::StatusCode::kResourceExhausted) << tight;
  EXPECT_NE(tight.message().find("declares 320 faces and 163 vertices"), std::string::npos) << tight;
}

// Files read from disk have no vertex limit, so any count within int32 would reach Draco: this
// fuzz_drc input's 436 bytes (bitstream 1.1) declare 656,877,351 faces, for which Draco asks
// 7.9 GB. Counts beyond what the bytes can encode are refused on every path, limit or not.
TEST(HostileDracoTest, EdgebreakerCountsTheBytesCannotHoldAreRefused) {
  const std::string fuzzed(
      "\x44\x52\x41\x43\x4f\x01\x01\x01\x01\x21\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x27\x27\x27\x27"
      "\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x27\x05"
      "\x05\x05\x05\x00\x08\x10\x11\x08\x11\x09\x09\x11\x12\x0d\x12\x0a\x0a\x12\x27\x27\x27\x27\x27\x27"
      "\x27\x27\x27\x2b\x65\x20\x69\x73\x20\x6e\x6f\x74\x20\x64\x65\x66\x69\x6e\x65\x64\x01\x01\x01\x00"
      "\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01"
      "\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x09\x2b\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01"
      "\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x02\x02\x01\x01\xb2\x95"
      "\x00\x00\x19\x20\x00\x20\x04\x00\x0a\x5f\xfb\xd4\x53\x7d\xaa\x01\x09\x02\x02\x03\x05\x05\x0c\x0d"
      "\x05\x0d\x06\x06\x0d\x0e\x0e\x07\x06\x07\x0e\x0f\x07\x0f\x00\x08\x10\x11\x08\x11\x09\x09\x11\x12"
      "\x0d\x12\x0a\x0a\x12\x13\x0a\x13\x0b\x0b\x13\x14\x0b\x14\x0c\x0c\x14\x15\x0c\x15\x0d\x0d\x15\x16"
      "\x0d\x17\x00\x00\x00\x00\x00\x00\x00\x0f\x17\x10\x0f\x10\x08\x90\x1f\x18\x10\x18\x11\x11\x18\x19"
      "\x11\x19\x12\x12\x19\x10\x12\x1a\x13\x13\x1a\x1b\x13\x1b\x14\x14\x1b\x1c\x14\x1c\x15\x15\x1c\x1d"
      "\x15\x1d\x16\x16\x1d\x1e\x16\x1e\x17\x17\x1e\x1f\x17\x1f\x10\x18\x20\x21\x18\x21\x19\x19\x21\x22"
      "\x19\x22\x1a\x1a\x44\x52\x41\x43\x4f\x02\x02\x01\x00\x00\x00\x06\x06\x01\x00\x02\x01\x00\x01\x03"
      "\x01\x02\x03\x00\x03\x02\x00\x01\x04\x02\x02\x03\x01\x01\x00\x09\x03\x00\x00\x00\x00\x00\x00\x00"
      "\x03\x01\x02\x03\x00\x03\x02\x00\x01\x04\x02\x02\x2a\x03\x01\x01\x00\x09\x03\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x5b\x00\x00\x00\x00\x00\x00\x80\x37\x00\x00\x00\x00\x00\x80\x3f\x00\x00"
      "\x80\x3f\x00\x00\x80\x3f\x00\x00\x80\x3f\x00\x22\x23\x1a\x23\x1b\x1b\x23\x24\x1b\x24\x1c\x00\xa0"
      "\x2f\x24\x2b\x2c",
      436);
  const std::string words = "436 bytes declare 656877351 faces";
  ExpectInvalid(DecodeDraco(fuzzed).status(), words);
  ExpectInvalid(ParseMesh(fuzzed, MeshFormat::kDraco).status(), words);
  ExpectInvalid(DracoMesh::Decode(fuzzed).status(), words);
  for (bool v22 : {false, true}) {
    const std::string head = EdgebreakerHead(v22, 1000, 600'000'000);
    ExpectInvalid(DecodeDraco(head).status(), "declare 600000000 faces");
    // A million faces fit any file, however short: Draco's own decoder judges those.
    const absl::Status floor = DecodeDraco(EdgebreakerHead(v22, 1000, 1 << 20)).status();
    EXPECT_EQ(floor.message().find("faces and"), std::string::npos) << floor;
  }
}

// Welded vertices of a decoded result, as a set of exact positions.
std::set<std::tuple<double, double, double>> VertexSet(const std::string& bytes) {
  std::set<std::tuple<double, double, double>> out;
  absl::StatusOr<Mesh> m = DecodeDraco(bytes);
  EXPECT_TRUE(m.ok()) << m.status();
  if (m.ok()) {
    for (const Vec3& p : m->positions) out.insert({p.x, p.y, p.z});
  }
  return out;
}

// Draco reads the count of its texture-coordinate predictor's orientation bits as any int32 and
// decodes that many (2^31: a 256 MB table and 5 s of CPU) before it sees the data has run out.
// Each 4-byte window of a textured Edgebreaker file is set to 2^31 - 1 in turn: where that is
// the count, the decode must be refused at once, as a block no valid encoding of that many faces
// needs (unbounded, it succeeds after seconds), and no window may make it succeed with a mesh of
// another size.
TEST(HostileDracoTest, CountsTheDeclaredFacesCannotNeedAreRefusedBeforeTheirWork) {
  using testing::TexturedEdgebreakerDraco;
  const Mesh sphere = Icosphere(1);
  const std::string good = TexturedEdgebreakerDraco(sphere);
  absl::StatusOr<Mesh> decoded = DecodeDraco(good);
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  int refused_blocks = 0;
  for (size_t i = 0; i + 4 <= good.size(); ++i) {
    std::string bad = good;
    const uint32_t count = 0x7fffffff;
    std::memcpy(bad.data() + i, &count, 4);
    absl::StatusOr<Mesh> got = DecodeDraco(bad);
    if (got.ok()) {
      EXPECT_EQ(got->triangles.size(), sphere.triangles.size()) << "window " << i;
    } else if (got.status().message().find("asked for a block of memory above") != std::string::npos) {
      ++refused_blocks;
      EXPECT_EQ(got.status().code(), absl::StatusCode::kInvalidArgument) << got.status();
      EXPECT_NE(got.status().message().find("80 faces"), std::string::npos) << got.status();
    }
  }
  std::printf("%zu windows of a %zu-byte file, %d refused for a block above the limit\n", good.size() - 3, good.size(),
              refused_blocks);
  EXPECT_GE(refused_blocks, 1);
}

// Every encoding of an awkward but valid mesh (seams, duplicate faces, a non-manifold edge, a
// face with a repeated index beside the vertex's other faces) decodes with Draco; lossless,
// its points are exactly the welded input's vertices, and sequential keeps every point.
TEST(HostileDracoTest, EveryAcceptedEncodingKeepsTheWeldedVertices) {
  Mesh m = Icosphere(2);
  for (Vec3& p : m.positions) p = RoundToFloat(p);
  const int32_t n = m.num_vertices();
  m.positions.push_back(m.positions[0]);  // a seam copy
  m.triangles.push_back(m.triangles[3]);  // a duplicate face
  m.positions.push_back({2, 2, 2});
  m.triangles.push_back({m.triangles[5][0], m.triangles[5][1], n + 1});  // a non-manifold edge
  m.triangles.push_back({1, 1, 2});                                      // a repeated index
  m.triangles.push_back({0, n, 7});
  absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(*EncodeDraco(m));
  ASSERT_TRUE(dm.ok()) << dm.status();
  const Mesh welded = dm->welded();
  std::set<std::tuple<double, double, double>> expected;
  for (const Vec3& p : welded.positions) expected.insert({p.x, p.y, p.z});
  ASSERT_EQ(expected.size(), welded.positions.size());
  for (DracoMethod method : {DracoMethod::kSequential, DracoMethod::kEdgebreaker}) {
    for (int bits : {0, 1, 11, kMaxQuantizationBits}) {
      SCOPED_TRACE(::testing::Message() << "edgebreaker " << (method == DracoMethod::kEdgebreaker) << " bits " << bits);
      DracoOptions o;
      o.method = method;
      o.quantization_bits = bits;
      absl::StatusOr<std::string> out = dm->Encode(welded, o);
      ASSERT_TRUE(out.ok()) << out.status();
      absl::StatusOr<Mesh> back = DecodeDraco(*out);
      ASSERT_TRUE(back.ok()) << back.status();
      if (method == DracoMethod::kSequential) {
        EXPECT_EQ(back->num_vertices(), m.num_vertices());
      }
      if (bits == 0) {
        EXPECT_EQ(VertexSet(*out), expected);
      }
    }
  }
}

}  // namespace
}  // namespace meshsmooth
