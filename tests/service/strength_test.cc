// Per-vertex strength through the service (JobSpec.strength_attribute) and the CLI's ways to
// give it (client/strength.h: --weight, --fixed, --region, --outside, --falloff): the service
// equals the core bit for bit, bad attributes and bad flags are refused naming them, a fixed
// file keeps its vertices' bits end to end, and a falloff leaves no crease at a region's edge.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "client/strength.h"
#include "client/transfer.h"
#include "core/io/mesh_io.h"
#include "core/measure/folded_faces.h"
#include "core/shapes/parametric.h"
#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"
#include "draco/metadata/geometry_metadata.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth {
namespace {

namespace fs = std::filesystem;
using namespace meshsmooth::testing;

// `mesh` as Draco bytes with `values` as the property `name` (a one-component float attribute).
std::string WithProperty(Mesh mesh, const std::string& name, const std::vector<float>& values) {
  mesh.properties.push_back({name, "float", std::vector<double>(values.begin(), values.end())});
  return *EncodeDraco(mesh);
}

// Strength 0 on the cap z > 0.3 of the unit sphere, 0.5 on every third vertex, else 1.
std::vector<float> CapAndHalves(const Mesh& m) {
  std::vector<float> s(m.positions.size(), 1.0f);
  for (size_t v = 0; v < s.size(); ++v) s[v] = m.positions[v].z > 0.3 ? 0.0f : v % 3 == 0 ? 0.5f : 1.0f;
  return s;
}

TEST(StrengthServiceTest, EqualsTheCoreBitForBit) {
  auto server = StartServer();
  ASSERT_TRUE(server);
  const Mesh mesh = FloatMesh(NoisySphere(3));
  const std::vector<float> strength = CapAndHalves(mesh);
  const std::string draco = WithProperty(mesh, "confidence", strength);
  for (const std::string& flow : {std::string("laplacian"), std::string("bilateral_normal"), std::string()}) {
    SCOPED_TRACE(flow.empty() ? "the default job" : flow);
    v1::JobSpec spec = flow.empty() ? v1::JobSpec() : Spec(flow, 4);
    spec.set_strength_attribute("confidence");
    absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), spec, draco);
    ASSERT_TRUE(out.ok()) << out.status();
    FlowParams p = flow.empty() ? FlowParams{} : Params(flow, 4);
    p.strength = strength;
    Mesh expected = mesh;
    ASSERT_TRUE(Smooth(expected, p).ok());
    const absl::StatusOr<Mesh> got = DecodeDraco(out->result);
    ASSERT_TRUE(got.ok());
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      ASSERT_EQ(got->positions[v], RoundToFloat(expected.positions[v])) << "vertex " << v;
      if (strength[v] == 0.0f) {
        ASSERT_EQ(got->positions[v], mesh.positions[v]) << "held vertex " << v;
      }
    }
    // The attribute comes back as it went.
    const absl::StatusOr<std::vector<float>> back = DecodeDracoAttribute(out->result, "confidence");
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(*back, strength);
  }
}

// No strength_attribute: the result of the job as before; an attribute of ones: the same bits.
TEST(StrengthServiceTest, OnesGiveTheBitsOfNoField) {
  auto server = StartServer();
  const Mesh mesh = FloatMesh(NoisySphere(3));
  const std::string draco = WithProperty(mesh, "w", std::vector<float>(mesh.positions.size(), 1.0f));
  for (v1::JobSpec spec : {v1::JobSpec(), Spec("taubin", 5)}) {
    absl::StatusOr<SmoothOutcome> plain = Call(server->InProcessChannel(), spec, draco);
    spec.set_strength_attribute("w");
    absl::StatusOr<SmoothOutcome> ones = Call(server->InProcessChannel(), spec, draco);
    ASSERT_TRUE(plain.ok() && ones.ok());
    EXPECT_EQ(DecodeDraco(plain->result)->positions, DecodeDraco(ones->result)->positions);
  }
}

// A three-component generic attribute named `name` on `mesh`'s points, as another client might send.
std::string WithVectorAttribute(const Mesh& mesh, const std::string& name) {
  draco::Mesh dm;
  dm.set_num_points(static_cast<uint32_t>(mesh.positions.size()));
  draco::GeometryAttribute pos;
  pos.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
  const int pid = dm.AddAttribute(pos, true, dm.num_points());
  draco::GeometryAttribute gen;
  gen.Init(draco::GeometryAttribute::GENERIC, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
  const int gid = dm.AddAttribute(gen, true, dm.num_points());
  for (uint32_t p = 0; p < dm.num_points(); ++p) {
    const Vec3& q = mesh.positions[p];
    const float xyz[3] = {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
    dm.attribute(pid)->SetAttributeValue(draco::AttributeValueIndex(p), xyz);
    const float half[3] = {0.5f, 0.5f, 0.5f};
    dm.attribute(gid)->SetAttributeValue(draco::AttributeValueIndex(p), half);
  }
  for (const Triangle& t : mesh.triangles) {
    dm.AddFace({draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
  }
  auto metadata = std::make_unique<draco::AttributeMetadata>();
  metadata->AddEntryString("name", name);
  dm.AddAttributeMetadata(gid, std::move(metadata));
  draco::Encoder encoder;
  encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
  draco::EncoderBuffer buffer;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(dm, &buffer).ok());
  return std::string(buffer.data(), buffer.size());
}

TEST(StrengthServiceTest, BadAttributesAreRefusedNamingTheField) {
  auto server = StartServer();
  const Mesh mesh = FloatMesh(NoisySphere(2));
  const size_t n = mesh.positions.size();
  std::vector<float> nan(n, 1.0f), high(n, 1.0f), low(n, 1.0f);
  nan[7] = std::nanf("");
  high[3] = 1.5f;
  low[5] = -0.5f;
  const struct {
    std::string what, draco, words;
  } cases[] = {
      {"no such attribute", WithProperty(mesh, "other", std::vector<float>(n, 1.0f)), "no attribute 'w'"},
      {"NaN", WithProperty(mesh, "w", nan), "vertex 7"},
      {"above 1", WithProperty(mesh, "w", high), "vertex 3 is 1.5"},
      {"below 0", WithProperty(mesh, "w", low), "vertex 5 is -0.5"},
      {"three components", WithVectorAttribute(mesh, "w"), "3 components"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    for (v1::JobSpec spec : {v1::JobSpec(), Spec("median", 2)}) {
      spec.set_strength_attribute("w");
      absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), spec, c.draco);
      ExpectStatus(out.status(), absl::StatusCode::kInvalidArgument, "strength_attribute 'w'");
      ExpectStatus(out.status(), absl::StatusCode::kInvalidArgument, c.words);
    }
  }
  // The server still serves.
  EXPECT_TRUE(Call(server->InProcessChannel(), Spec("median", 2), *EncodeDraco(mesh)).ok());
}

client::StrengthOptions Weight(const std::string& weight) {
  client::StrengthOptions o;
  o.weight = weight;
  return o;
}
client::StrengthOptions Fixed(const std::string& file) {
  client::StrengthOptions o;
  o.fixed = file;
  return o;
}
client::StrengthOptions Region(const std::string& region, double falloff = 0.0, bool outside = false) {
  client::StrengthOptions o;
  o.region = region;
  o.falloff = falloff;
  o.outside = outside;
  return o;
}

class StrengthCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = StartServer();
    ASSERT_NE(server_, nullptr);
    dir_ = fs::temp_directory_path() /
           ("meshsmooth_strength_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  // The CLI's path (client/commands.cc) from `input` to `output` with `strength`.
  absl::StatusOr<Mesh> SmoothFile(const std::string& input, const std::string& output,
                                  const client::StrengthOptions& strength, v1::JobSpec spec) {
    absl::StatusOr<client::Upload> upload = client::PrepareUpload(input, false, false, strength);
    if (!upload.ok()) return upload.status();
    EXPECT_TRUE(upload->strength);
    spec.set_strength_attribute(client::kStrengthAttribute);
    absl::StatusOr<SmoothOutcome> outcome = Call(server_->InProcessChannel(), spec, upload->draco);
    if (!outcome.ok()) return outcome.status();
    if (absl::Status s = client::WriteResult(*upload, outcome->result, output, false); !s.ok()) return s;
    return ReadMesh(output);
  }

  std::unique_ptr<server::Server> server_;
  fs::path dir_;
};

TEST_F(StrengthCliTest, FixedFileKeepsItsVerticesBitForBit) {
  Mesh noisy = NoisySphere(3);
  ASSERT_TRUE(WriteMesh(Path("in.ply"), noisy).ok());
  const absl::StatusOr<Mesh> input = ReadMesh(Path("in.ply"));
  ASSERT_TRUE(input.ok());
  std::vector<uint8_t> fixed(input->positions.size(), 0);
  {
    std::ofstream f(Path("fixed.txt"));
    f << "# held vertices\n";
    for (size_t v = 0; v < fixed.size(); ++v) {
      if (input->positions[v].x > 0.2 || v % 11 == 0) {
        fixed[v] = 1;
        f << v << (v % 4 == 0 ? "\n" : ", ");
      }
    }
  }
  client::StrengthOptions o;
  o.fixed = Path("fixed.txt");
  for (v1::JobSpec spec : {v1::JobSpec(), Spec("laplacian", 10), Spec("guided_normal", 3)}) {
    SCOPED_TRACE(spec.flow().empty() ? "the default job" : spec.flow());
    const absl::StatusOr<Mesh> out = SmoothFile(Path("in.ply"), Path("out.ply"), o, spec);
    ASSERT_TRUE(out.ok()) << out.status();
    int64_t moved = 0;
    for (size_t v = 0; v < fixed.size(); ++v) {
      if (fixed[v]) {
        ASSERT_EQ(std::memcmp(&out->positions[v], &input->positions[v], sizeof(Vec3)), 0) << "fixed vertex " << v;
      } else {
        moved += !(out->positions[v] == input->positions[v]);
      }
    }
    EXPECT_GT(moved, 0);
    EXPECT_TRUE(out->properties.empty()) << "the strength went into the output";
  }
}

TEST_F(StrengthCliTest, BadFlagsAreRefusedNamingThem) {
  Mesh mesh = Icosphere(2);
  mesh.properties.push_back({"quality", "float", std::vector<double>(mesh.positions.size(), 3.0)});
  ASSERT_TRUE(WriteMesh(Path("in.ply"), mesh).ok());
  {
    std::ofstream(Path("range.txt")) << "1 2 3\n9999\n";
    std::ofstream(Path("word.txt")) << "1 two 3\n";
  }
  const struct {
    client::StrengthOptions o;
    std::string words;
  } cases[] = {
      {Weight("confidence"), "--weight confidence: the input has no vertex property 'confidence' (it has quality)"},
      {Weight("quality"), "outside [0, 1]"},
      {Weight("quality:1,1"), "--weight quality:1,1"},
      {Fixed(Path("range.txt")), "line 2: index 9999 is out of range"},
      {Fixed(Path("word.txt")), "'two' is not a vertex index"},
      {Fixed(Path("missing.txt")), "cannot read"},
      {Region("box:0,0,0,1,1"), "--region box:0,0,0,1,1"},
      {Region("sphere:0,0,0,-1"), "radius above 0"},
      {Region("cone:1,2"), "--region cone:1,2"},
      {Region("", 0.0, true), "--outside needs a --region"},
      {Region("sphere:0,0,0,1", -1.0), "--falloff"},
      {Region("", 0.5), "--falloff needs a --region"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.words);
    const absl::StatusOr<client::Upload> upload = client::PrepareUpload(Path("in.ply"), false, false, c.o);
    ExpectStatus(upload.status(), absl::StatusCode::kInvalidArgument, c.words);
  }
  // The quality mapped onto [0, 1] is taken.
  EXPECT_TRUE(client::PrepareUpload(Path("in.ply"), false, false, Weight("quality:0,6")).ok());
}

TEST(StrengthRegionTest, ValuesInsideOutsideAndOnTheFalloff) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1.5, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  client::StrengthOptions o = Region("sphere:0,0,0,1", 2.0);
  absl::StatusOr<std::vector<float>> s = client::VertexStrength(mesh, o);
  ASSERT_TRUE(s.ok()) << s.status();
  // Distances to the edge 0 (inside), 0.5, 1 and 2: smoothstep 1 - t^2 (3 - 2t) at t = d / 2.
  EXPECT_EQ((*s)[0], 1.0f);
  EXPECT_FLOAT_EQ((*s)[1], 1.0f - 0.0625f * 2.5f);
  EXPECT_FLOAT_EQ((*s)[2], 0.5f);
  EXPECT_EQ((*s)[3], 0.0f);
  o.outside = true;
  s = client::VertexStrength(mesh, o);
  EXPECT_EQ((*s)[0], 0.0f);
  EXPECT_EQ((*s)[3], 1.0f);
  o = Region("box:-1,-1,-1,1,1,1");
  s = client::VertexStrength(mesh, o);
  EXPECT_EQ(*s, (std::vector<float>{1, 0, 0, 0}));
}

// The largest angle (degrees) between a face's normal and the normal of a face across one of
// its edges, over the faces at a region's edge or on its falloff: those whose vertices'
// strengths differ or lie strictly between 0 and 1.
double LargestTurnAtEdge(const Mesh& m, const std::vector<float>& strength) {
  const Topology topo = BuildTopology(m);
  const FaceFolds folds(m, topo);
  double largest = 0.0;
  for (int32_t i = 0; i < static_cast<int32_t>(topo.faces.size()); ++i) {
    const Triangle& t = folds.face(i);
    const float lo = std::min({strength[t[0]], strength[t[1]], strength[t[2]]});
    const float hi = std::max({strength[t[0]], strength[t[1]], strength[t[2]]});
    if (lo == hi && (lo == 0.0f || lo == 1.0f)) continue;  // away from the edge
    const Vec3 n = Cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]);
    for (int32_t g : folds.across(i)) {
      const Triangle& u = folds.face(g);
      const Vec3 k = Cross(m.positions[u[1]] - m.positions[u[0]], m.positions[u[2]] - m.positions[u[0]]);
      largest = std::max(largest, std::acos(std::clamp(Dot(n, k) / (Norm(n) * Norm(k)), -1.0, 1.0)));
    }
  }
  return largest * 180.0 / std::numbers::pi;
}

// A smooth sphere's cap (a region of radius 0.8 around a pole of the unit sphere) shrinks under
// 60 umbrella iterations while the rest stays: without a falloff a face at the cap's edge turns
// by more than 15 degrees (24 here) from a neighbour; with a falloff of 0.75 no face of the ramp
// or at its ends turns more than 6 degrees (4.3 here; 7.6 with a falloff of 0.5, 16 with 0.25).
TEST(StrengthRegionTest, FalloffLeavesNoCreaseAtTheRegionsEdge) {
  const Mesh sphere = Icosphere(4);
  const FlowParams base = Params("laplacian", 60, 0.5);
  client::StrengthOptions o = Region("sphere:0,0,1,0.8");
  FlowParams p = base;
  p.strength = *client::VertexStrength(sphere, o);
  Mesh sharp = sphere;
  ASSERT_TRUE(Smooth(sharp, p).ok());
  const double sharp_turn = LargestTurnAtEdge(sharp, p.strength);
  o.falloff = 0.75;
  p.strength = *client::VertexStrength(sphere, o);
  Mesh soft = sphere;
  ASSERT_TRUE(Smooth(soft, p).ok());
  const double soft_turn = LargestTurnAtEdge(soft, p.strength);
  EXPECT_GT(sharp_turn, 15.0);
  EXPECT_LT(soft_turn, 6.0);
}

}  // namespace
}  // namespace meshsmooth
