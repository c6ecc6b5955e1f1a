#include "core/io/draco_codec.h"

#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"
#include "draco/metadata/geometry_metadata.h"
#include "gtest/gtest.h"
#include "tests/hostile_inputs.h"
#include "tests/test_data.h"

namespace meshsmooth {
namespace {

Mesh FloatNoisySphere(int level) {
  Mesh m = Icosphere(level);
  AddUniformNoise(m, 0.3, 11);
  for (Vec3& p : m.positions) p = RoundToFloat(p);
  return m;
}

// FloatNoisySphere(1) and one more point, n, a copy of vertex 0 that half of vertex 0's faces
// use instead: a seam that DracoMesh welds back into vertex 0.
Mesh SphereWithASeamCopy() {
  Mesh m = FloatNoisySphere(1);
  const int32_t n = m.num_vertices();
  m.positions.push_back(m.positions[0]);
  int32_t split = 0;
  for (Triangle& t : m.triangles) {
    for (int32_t& v : t) {
      if (v == 0 && split++ % 2 == 0) v = n;
    }
  }
  EXPECT_GT(split, 1);
  return m;
}

TEST(DracoCodecTest, LosslessSequentialKeepsOrderAndExactFloats) {
  const Mesh m = FloatNoisySphere(3);
  absl::StatusOr<std::string> bytes = EncodeDraco(m);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  absl::StatusOr<Mesh> back = DecodeDraco(*bytes);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->triangles, m.triangles);
  EXPECT_EQ(back->positions, m.positions);
}

TEST(DracoCodecTest, QuantizedRoundTripWithinHalfAGridStep) {
  const Mesh m = FloatNoisySphere(3);
  Vec3 lo = m.positions[0], hi = m.positions[0];
  for (const Vec3& p : m.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  for (int q : {8, 11, 14, 20}) {
    for (DracoMethod method : {DracoMethod::kSequential, DracoMethod::kEdgebreaker}) {
      DracoOptions o;
      o.quantization_bits = q;
      o.method = method;
      absl::StatusOr<std::string> bytes = EncodeDraco(m, o);
      ASSERT_TRUE(bytes.ok()) << bytes.status();
      absl::StatusOr<Mesh> back = DecodeDraco(*bytes);
      ASSERT_TRUE(back.ok()) << back.status();
      ASSERT_EQ(back->positions.size(), m.positions.size());
      ASSERT_EQ(back->triangles.size(), m.triangles.size());
      // Float32 arithmetic inside Draco adds a few ulps on top of the grid error.
      const double bound = extent / (std::pow(2.0, q) - 1.0) / 2.0 * (1.0 + 1e-6) + 1e-6 * extent;
      if (method == DracoMethod::kSequential) {
        EXPECT_EQ(back->triangles, m.triangles);
        for (size_t i = 0; i < m.positions.size(); ++i) {
          const Vec3 d = back->positions[i] - m.positions[i];
          ASSERT_LE(std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)}), bound) << "q=" << q << " vertex " << i;
        }
      } else {
        // Edgebreaker reorders: compare each decoded vertex with its nearest original through
        // the faces' geometry instead; the closed-sphere topology must survive.
        const ValidationReport r = Validate(*back);
        EXPECT_TRUE(r.closed());
        EXPECT_EQ(r.euler_characteristic(), 2);
      }
    }
  }
}

TEST(DracoCodecTest, EdgebreakerLosslessKeepsTheVertexSet) {
  const Mesh m = FloatNoisySphere(2);
  DracoOptions o;
  o.method = DracoMethod::kEdgebreaker;
  absl::StatusOr<std::string> bytes = EncodeDraco(m, o);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  absl::StatusOr<Mesh> back = DecodeDraco(*bytes);
  ASSERT_TRUE(back.ok());
  auto key = [](const Vec3& p) { return std::make_tuple(p.x, p.y, p.z); };
  std::vector<std::tuple<double, double, double>> a, b;
  for (const Vec3& p : m.positions) a.push_back(key(p));
  for (const Vec3& p : back->positions) b.push_back(key(p));
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  EXPECT_EQ(a, b);
}

// What a server sizes a job by from the first chunk of its upload: the counts at the head of the
// bytes, for both methods, after a metadata block, and nothing from a head too short to hold them.
TEST(DracoCodecTest, DeclaredCountsAreReadFromTheHead) {
  Mesh m = FloatNoisySphere(4);
  const int64_t vertices = m.num_vertices(), faces = static_cast<int64_t>(m.triangles.size());
  for (const DracoMethod method : {DracoMethod::kSequential, DracoMethod::kEdgebreaker}) {
    SCOPED_TRACE(method == DracoMethod::kSequential ? "sequential" : "edgebreaker");
    DracoOptions o;
    o.method = method;
    absl::StatusOr<std::string> bytes = EncodeDraco(m, o);
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    const std::optional<DracoCounts> counts = DracoDeclaredCounts(std::string_view(*bytes).substr(0, 64));
    ASSERT_TRUE(counts.has_value());
    EXPECT_EQ(counts->faces, faces);
    if (method == DracoMethod::kSequential) {
      EXPECT_EQ(counts->points, vertices);
    } else {
      EXPECT_GE(counts->points, vertices);  // an upper bound
      EXPECT_LE(counts->points, 2 * vertices);
    }
    EXPECT_FALSE(DracoDeclaredCounts(std::string_view(*bytes).substr(0, 11)).has_value());
  }
  // A named vertex property: its name travels in the metadata block ahead of the counts.
  m.properties.push_back({"quality", "float", std::vector<double>(m.positions.size(), 0.5)});
  absl::StatusOr<std::string> with_metadata = EncodeDraco(m);
  ASSERT_TRUE(with_metadata.ok()) << with_metadata.status();
  const std::optional<DracoCounts> counts = DracoDeclaredCounts(*with_metadata);
  ASSERT_TRUE(counts.has_value());
  EXPECT_EQ(counts->faces, faces);
  EXPECT_EQ(counts->points, vertices);
  EXPECT_FALSE(DracoDeclaredCounts("not Draco bytes at all").has_value());
}

TEST(DracoCodecTest, BadOptionsAndEmptyInputAreRefused) {
  DracoOptions o;
  o.quantization_bits = 31;
  EXPECT_EQ(EncodeDraco(Icosphere(0), o).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodeDraco(Mesh{}).status().code(), absl::StatusCode::kInvalidArgument);
  const absl::Status empty = DecodeDraco("").status();
  EXPECT_EQ(empty.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(empty.message().find("empty"), std::string::npos);
  const absl::Status garbage = DecodeDraco("this is not draco at all").status();
  EXPECT_EQ(garbage.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(garbage.message().find("Draco"), std::string::npos) << garbage;
}

TEST(DracoCodecTest, MeshWithoutFacesIsRefusedAsEmpty) {
  Mesh points;
  points.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const absl::Status enc = EncodeDraco(points).status();
  EXPECT_EQ(enc.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(enc.message().find("empty"), std::string::npos) << enc;
  // The same mesh encoded by Draco directly.
  draco::Mesh dm;
  testing::PutThreePoints(dm, 0.0f, 0.0f);
  draco::Encoder encoder;
  encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
  draco::EncoderBuffer buf;
  ASSERT_TRUE(encoder.EncodeMeshToBuffer(dm, &buf).ok());
  const absl::Status s = DecodeDraco(std::string_view(buf.data(), buf.size())).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("empty"), std::string::npos) << s;
}

// Draco's sequential decoder refuses more than 3 points per face, so the encoder refuses to
// write such a mesh (unreferenced vertices, or faces out of range left out): no Draco decoder
// would read the bytes. A fuzz_drc input.
TEST(DracoCodecTest, MorePointsThanThreePerFaceAreRefusedForSequential) {
  Mesh m;
  for (int i = 0; i < 7; ++i) m.positions.push_back({static_cast<double>(i), 0.5 * i * i, 0.0});
  m.triangles = {{0, 1, 2}, {0, 1, 9}};  // one face in range for 7 points
  const absl::StatusOr<std::string> seq = EncodeDraco(m);
  ASSERT_FALSE(seq.ok()) << "encoded; decoding it gives " << DecodeDraco(*seq).status();
  EXPECT_EQ(seq.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(seq.status().message().find("more than 3 points per face"), std::string::npos) << seq.status();

  m.positions.resize(6);  // 6 points, 2 faces once the second is in range: within the limit
  m.triangles[1] = {0, 1, 5};
  const absl::StatusOr<std::string> ok = EncodeDraco(m);
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_TRUE(DecodeDraco(*ok).ok());
}

// Draco's quantizer divides by the positions' extent in float32, so for a mesh a few 1e-38
// wide the grid overflows and the decoded vertices land at -1.2e-32, a million boxes away from
// the mesh (a fuzz_job input). Quantization needs an extent of at least kMinQuantizedExtent (or
// none at all); within that the round trip stays on the grid.
TEST(DracoCodecTest, ExtentTooSmallToQuantizeIsRefused) {
  for (int bits : {1, 12, kMaxQuantizationBits}) {
    for (DracoMethod method : {DracoMethod::kSequential, DracoMethod::kEdgebreaker}) {
      Mesh tiny = Icosphere(1);
      for (Vec3& p : tiny.positions) p = RoundToFloat(p * 1e-38);
      const absl::StatusOr<std::string> refused = EncodeDraco(tiny, {bits, method});
      ASSERT_FALSE(refused.ok()) << bits << " bits: decodes to " << DecodeDraco(*refused)->positions[0].x << " for "
                                 << tiny.positions[0].x;
      EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
      EXPECT_NE(refused.status().message().find("too small to quantize"), std::string::npos) << refused.status();
      EXPECT_TRUE(EncodeDraco(tiny, {0, method}).ok()) << "lossless output has no grid";

      // Scaled to the smallest extent quantization takes: every coordinate within half a step.
      Mesh small = Icosphere(1);
      for (Vec3& p : small.positions) p = RoundToFloat(p * (kMinQuantizedExtent / 2));
      const absl::StatusOr<std::string> bytes = EncodeDraco(small, {bits, method});
      ASSERT_TRUE(bytes.ok()) << bytes.status();
      const absl::StatusOr<Mesh> back = DecodeDraco(*bytes);
      ASSERT_TRUE(back.ok()) << back.status();
      for (const Vec3& p : back->positions) {
        for (double c : {p.x, p.y, p.z}) EXPECT_LE(std::abs(c), 1.01 * kMinQuantizedExtent / 2) << bits << " bits";
      }
    }
  }
}

// A job takes the welded mesh instead of copying it; Encode() then still knows the vertex
// count and writes each vertex back to every point welded into it.
TEST(DracoCodecTest, TakenWeldedMeshEncodesBackToEveryPoint) {
  const Mesh m = SphereWithASeamCopy();
  const int32_t n = m.num_vertices() - 1;
  absl::StatusOr<std::string> bytes = EncodeDraco(m);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(*bytes);
  ASSERT_TRUE(dm.ok()) << dm.status();
  EXPECT_EQ(dm->seam_points(), 1);

  Mesh welded = dm->TakeWelded();
  ASSERT_EQ(welded.num_vertices(), n);
  EXPECT_EQ(dm->welded().num_vertices(), 0);
  const std::vector<Vec3> input = dm->InputPositions();  // the taken positions, made anew
  ASSERT_EQ(input.size(), welded.positions.size());
  EXPECT_EQ(std::memcmp(input.data(), welded.positions.data(), input.size() * sizeof(Vec3)), 0);
  for (Vec3& p : welded.positions) p *= 2.0;
  absl::StatusOr<std::string> out = dm->Encode(welded);
  ASSERT_TRUE(out.ok()) << out.status();
  absl::StatusOr<Mesh> back = DecodeDraco(*out);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->num_vertices(), n + 1);
  for (int32_t v = 0; v < n; ++v) EXPECT_EQ(back->positions[v], m.positions[v] * 2.0) << v;
  EXPECT_EQ(back->positions[n], back->positions[0]);

  welded.positions.push_back({});
  const absl::Status wrong = dm->Encode(welded).status();
  EXPECT_EQ(wrong.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(wrong.message().find("expected " + std::to_string(n) + " positions"), std::string::npos) << wrong;
}

// Draco's own bitstreams, versions 0.9 to 2.2, with the vertex and face counts each file holds.
TEST(DracoCodecTest, DecodesDracosOwnTestFiles) {
  MESHSMOOTH_REQUIRE_SHARED("draco");
  struct Expect {
    const char* file;
    uint32_t vertices_min, vertices_max, faces;
  };
  const Expect meshes[] = {
      {"bunny_gltf.drc", 34834, 34834, 69451},
      {"car.drc", 1856, 1856, 1744},
      {"cube_att.drc", 24, 24, 12},
      {"cube_att.obj.edgebreaker.cl10.2.2.drc", 24, 24, 12},
      {"cube_att.obj.edgebreaker.cl4.2.2.drc", 24, 24, 12},
      {"cube_att.obj.sequential.cl3.2.2.drc", 24, 24, 12},
      {"cube_att_sub_o_2.drc", 26, 26, 12},
      {"cube_att_sub_o_no_metadata.drc", 26, 26, 12},
      {"octagon_preserved.drc", 16, 16, 6},
      {"test_nm.obj.edgebreaker.0.10.0.drc", 97, 99, 170},
      {"test_nm.obj.edgebreaker.0.9.1.drc", 97, 99, 170},
      {"test_nm.obj.edgebreaker.1.0.0.drc", 97, 99, 170},
      {"test_nm.obj.edgebreaker.1.1.0.drc", 97, 99, 170},
      {"test_nm.obj.edgebreaker.cl10.2.2.drc", 97, 99, 170},
      {"test_nm.obj.edgebreaker.cl4.2.2.drc", 97, 99, 170},
      {"test_nm.obj.sequential.0.10.0.drc", 97, 99, 170},
      {"test_nm.obj.sequential.0.9.1.drc", 97, 99, 170},
      {"test_nm.obj.sequential.1.0.0.drc", 97, 99, 170},
      {"test_nm.obj.sequential.1.1.0.drc", 97, 99, 170},
      {"test_nm.obj.sequential.cl3.2.2.drc", 97, 99, 170},
      {"test_nm_quant.0.9.0.drc", 99, 99, 170},
  };
  for (const Expect& e : meshes) {
    SCOPED_TRACE(e.file);
    absl::StatusOr<std::string> bytes = ReadFileBytes((testing::SharedData("draco") / e.file).string());
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    absl::StatusOr<Mesh> m = DecodeDraco(*bytes);
    ASSERT_TRUE(m.ok()) << m.status();
    EXPECT_GE(m->positions.size(), e.vertices_min);
    EXPECT_LE(m->positions.size(), e.vertices_max);
    EXPECT_EQ(m->triangles.size(), e.faces);
    const ValidationReport r = Validate(*m);
    EXPECT_EQ(r.faces_out_of_range, 0);
    EXPECT_EQ(r.non_finite_vertices, 0);
  }
  for (const char* pc : {"cube_pc.drc", "pc_color.drc", "pc_kd_color.drc", "point_cloud_no_qp.drc"}) {
    absl::StatusOr<std::string> bytes = ReadFileBytes((testing::SharedData("draco") / pc).string());
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    const absl::Status s = DecodeDraco(*bytes).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << pc;
    EXPECT_NE(s.message().find("point cloud"), std::string::npos) << pc << ": " << s;
  }
}

// A few thousand bit-flipped and truncated buffers through decode + validate: no crash, no
// abort, no sanitizer report; whatever decodes must be safe to validate.
TEST(DracoCodecTest, SeededCorruptionNeverCrashes) {
  std::vector<std::string> seeds;
  for (DracoMethod method : {DracoMethod::kSequential, DracoMethod::kEdgebreaker}) {
    for (int q : {0, 11}) {
      DracoOptions o;
      o.method = method;
      o.quantization_bits = q;
      seeds.push_back(*EncodeDraco(FloatNoisySphere(2), o));
    }
  }
  uint64_t x = 0x243f6a8885a308d3ULL;
  auto next = [&x] {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return x;
  };
  int decoded = 0, refused = 0;
  for (int i = 0; i < 3000; ++i) {
    std::string buf = seeds[i % seeds.size()];
    if (i % 3 == 2) {
      buf.resize(next() % buf.size());
    } else {
      const int flips = 1 + static_cast<int>(next() % 4);
      for (int k = 0; k < flips; ++k) buf[next() % buf.size()] ^= static_cast<char>(1u << (next() % 8));
    }
    absl::StatusOr<Mesh> m = DecodeDraco(buf);
    if (m.ok()) {
      ++decoded;
      Validate(*m);
    } else {
      ++refused;
      EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument);
    }
  }
  EXPECT_EQ(decoded + refused, 3000);
  EXPECT_GT(refused, 1000);
}

// DracoMesh::Encode's extra attributes: each vertex's value reaches every point of the vertex
// (its seam copies too) in the type given, and an attribute of the same name is replaced, so
// each name is there once and its metadata names the new values.
TEST(DracoCodecTest, ExtraAttributesReachEveryPointAndReplaceTheirName) {
  Mesh m = SphereWithASeamCopy();
  const int32_t n = m.num_vertices() - 1;
  m.properties.push_back({"confidence", "float", std::vector<double>(n + 1, 9.0)});
  absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(*EncodeDraco(m));
  ASSERT_TRUE(dm.ok()) << dm.status();
  ASSERT_EQ(dm->welded().num_vertices(), n);
  std::vector<uint8_t> labels(n);
  std::vector<float> weights(n);
  for (int32_t v = 0; v < n; ++v) {
    labels[v] = static_cast<uint8_t>(v % 7 + 1);
    weights[v] = 0.25f * v;
  }
  absl::StatusOr<std::string> out = dm->Encode(dm->welded(), {}, {{"label", labels}, {"confidence", weights}});
  ASSERT_TRUE(out.ok()) << out.status();

  std::unique_ptr<draco::Mesh> raw = *DecodeDracoMesh(*out);
  int confidences = 0;
  for (int32_t i = 0; i < raw->num_attributes(); ++i) {
    std::string name;
    const draco::AttributeMetadata* md = raw->GetAttributeMetadataByAttributeId(i);
    if (md != nullptr && md->GetEntryString("name", &name) && name == "confidence") ++confidences;
  }
  EXPECT_EQ(confidences, 1);
  EXPECT_EQ(raw->GetNamedAttribute(draco::GeometryAttribute::GENERIC, 0)->data_type(), draco::DT_UINT8);
  absl::StatusOr<std::vector<float>> label = DecodeDracoAttribute(*out, "label");
  absl::StatusOr<std::vector<float>> confidence = DecodeDracoAttribute(*out, "confidence");
  ASSERT_TRUE(label.ok() && confidence.ok()) << label.status() << confidence.status();
  ASSERT_EQ(label->size(), static_cast<size_t>(n + 1));
  ASSERT_EQ(confidence->size(), static_cast<size_t>(n + 1));
  for (int32_t p = 0; p <= n; ++p) {
    const int32_t v = p < n ? p : 0;
    EXPECT_EQ((*label)[p], labels[v]) << p;
    EXPECT_EQ((*confidence)[p], weights[v]) << p;
  }

  const absl::Status short_one = dm->Encode(dm->welded(), {}, {{"label", std::vector<uint8_t>(n - 1)}}).status();
  EXPECT_EQ(short_one.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(short_one.message(), absl::StrCat("attribute 'label' has ", n - 1, " values for ", n, " vertices"));
  EXPECT_EQ(DecodeDracoAttribute(*out, "quality").status().code(), absl::StatusCode::kNotFound);
}

// A decoded mesh keeps the first TEX_COORD, NORMAL of 3 and COLOR of 3 or more components, and
// each named one-component attribute as a vertex property; every other attribute is named in
// `dropped`, with its index, type, name and components.
TEST(DracoCodecTest, AttributesAMeshCannotHoldAreNamedAsDropped) {
  draco::Mesh dm;
  dm.set_num_points(3);
  auto add = [&dm](draco::GeometryAttribute::Type type, int components, draco::DataType dt, const char* name) {
    draco::GeometryAttribute ga;
    ga.Init(type, nullptr, components, dt, dt == draco::DT_UINT8, draco::DataTypeLength(dt) * components, 0);
    const int id = dm.AddAttribute(ga, /*identity_mapping=*/true, 3);
    for (uint32_t p = 0; p < 3; ++p) {
      const float f[4] = {p == 1 ? 1.0f : 0.0f, p == 2 ? 1.0f : 0.0f, 0.5f, 0.5f};
      const uint16_t u16[4] = {static_cast<uint16_t>(100 * p), 1, 2, 3};
      const uint8_t u8[4] = {static_cast<uint8_t>(100 * p), 1, 2, 3};
      const void* value = dt == draco::DT_FLOAT32  ? static_cast<const void*>(f)
                          : dt == draco::DT_UINT16 ? static_cast<const void*>(u16)
                                                   : static_cast<const void*>(u8);
      dm.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(p), value);
    }
    if (name != nullptr) {
      auto metadata = std::make_unique<draco::AttributeMetadata>();
      metadata->AddEntryString("name", name);
      dm.AddAttributeMetadata(id, std::move(metadata));
    }
  };
  add(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32, nullptr);
  add(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32, nullptr);
  add(draco::GeometryAttribute::TEX_COORD, 2, draco::DT_FLOAT32, nullptr);  // a second set
  add(draco::GeometryAttribute::GENERIC, 1, draco::DT_FLOAT32, nullptr);    // no name
  add(draco::GeometryAttribute::GENERIC, 2, draco::DT_FLOAT32, "pair");     // two components
  add(draco::GeometryAttribute::GENERIC, 1, draco::DT_UINT16, "quality");   // a property
  add(draco::GeometryAttribute::NORMAL, 2, draco::DT_FLOAT32, nullptr);     // not 3 components
  add(draco::GeometryAttribute::COLOR, 4, draco::DT_UINT8, nullptr);        // normalized: 0..1
  dm.AddFace({draco::PointIndex(0), draco::PointIndex(1), draco::PointIndex(2)});
  draco::Encoder encoder;
  encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
  draco::EncoderBuffer buf;
  ASSERT_TRUE(encoder.EncodeMeshToBuffer(dm, &buf).ok());

  std::vector<std::string> dropped;
  absl::StatusOr<Mesh> m = DecodeDraco(std::string_view(buf.data(), buf.size()), &dropped);
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(dropped,
            (std::vector<std::string>{
                "Draco attribute 2 (TEX_COORD, 2 components)", "Draco attribute 3 (GENERIC, 1 components)",
                "Draco attribute 4 (GENERIC 'pair', 2 components)", "Draco attribute 6 (NORMAL, 2 components)"}));
  EXPECT_EQ(m->uvs.values, (std::vector<double>{0, 0, 1, 0, 0, 1}));
  EXPECT_EQ(m->uvs.corners, (std::vector<int32_t>{0, 1, 2}));
  EXPECT_TRUE(m->normals.empty());
  ASSERT_EQ(m->properties.size(), 1u);
  EXPECT_EQ(m->properties[0].name, "quality");
  EXPECT_EQ(m->properties[0].type, "float");
  EXPECT_EQ(m->properties[0].values, (std::vector<double>{0, 100, 200}));
  EXPECT_EQ(m->colors, (std::vector<Rgb>{{0, 1, 2}, {100, 1, 2}, {200, 1, 2}}));
}

}  // namespace
}  // namespace meshsmooth
