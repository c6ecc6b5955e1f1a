// Shape enhancement through the service (JobSpec.enhance): a degree-8 bump on a sphere grows by
// the gain through a real (loopback) server, equal to the core's result bit for bit, with the
// radius kept and no face turned over, by either method; the summary counts the vertices held back where a face
// would turn; strength 0 holds a vertex; a noisy input is refused or
// smoothed first; bad gains, scales, methods and smoothing fields are refused naming the field;
// ListFlows lists the fields.
#include <cmath>
#include <string>
#include <vector>

#include "core/io/draco_codec.h"
#include "core/job/enhance.h"
#include "gtest/gtest.h"
#include "tests/bump_sphere.h"
#include "tests/flow_fixtures.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

v1::JobSpec EnhanceSpec(double gain, double detail_scale) {
  v1::JobSpec spec;
  spec.mutable_enhance()->set_gain(gain);
  spec.mutable_enhance()->set_detail_scale(detail_scale);
  return spec;
}

TEST(EnhanceServiceTest, GainMultipliesTheBumpThroughARealServer) {
  auto server = StartServer({}, /*listen=*/true);
  ASSERT_TRUE(server);
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(server->port()), grpc::InsecureChannelCredentials());
  const int l = 8;
  const Mesh start = FloatMesh(BumpySphere(5, l, 0.002));
  const std::string draco = *EncodeDraco(start);
  const BumpFit before = FitBump(start, l);
  for (double gain : {2.0, 3.0}) {
    SCOPED_TRACE(::testing::Message() << "gain " << gain);
    absl::StatusOr<SmoothOutcome> out = Call(channel, EnhanceSpec(gain, 4.0), draco);
    ASSERT_TRUE(out.ok()) << out.status();
    const absl::StatusOr<Mesh> got = DecodeDraco(out->result);
    ASSERT_TRUE(got.ok());
    const BumpFit after = FitBump(*got, l);
    EXPECT_NEAR(after.amplitude / before.amplitude, gain, 0.1 * gain);
    EXPECT_NEAR(after.radius / before.radius, 1.0, 0.005);
    EXPECT_EQ(FlippedFaces(start, *got), 0);
    const v1::EffectiveParameters& p = out->summary.parameters();
    ASSERT_TRUE(p.has_enhance());
    EXPECT_EQ(p.enhance().gain(), gain);
    EXPECT_EQ(p.enhance().detail_scale(), 4.0);
    EXPECT_NEAR(p.enhance().detail_scale_h() * p.mean_edge_length(), 4.0, 1e-9);
    EXPECT_EQ(p.iterations_run(), 0u);
    EXPECT_EQ(p.flow(), "");
    EXPECT_EQ(p.enhance_held_back(), 0);
    EXPECT_EQ(out->summary.flipped_normals(), 0);
    // The service runs the core's Enhance: the same positions, rounded to float32.
    Mesh expected = start;
    EnhanceParams e;
    e.gain = gain;
    e.detail_scale = 4.0;
    Topology topo = BuildTopology(expected);
    ASSERT_TRUE(Enhance(expected, topo, e).ok());
    for (size_t v = 0; v < start.positions.size(); ++v) {
      ASSERT_EQ(got->positions[v], RoundToFloat(expected.positions[v])) << "vertex " << v;
    }
  }
}

TEST(EnhanceServiceTest, TheInvertedFlowThroughTheServiceMultipliesTheBump) {
  auto server = StartServer();
  const int l = 8;
  const Mesh start = FloatMesh(BumpySphere(5, l, 0.002));
  v1::JobSpec spec = EnhanceSpec(2.0, 4.0);
  spec.mutable_enhance()->set_method(v1::ENHANCE_METHOD_INVERTED_FLOW);
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), spec, *EncodeDraco(start));
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(out->summary.parameters().enhance().method(), v1::ENHANCE_METHOD_INVERTED_FLOW);
  const absl::StatusOr<Mesh> got = DecodeDraco(out->result);
  ASSERT_TRUE(got.ok());
  const BumpFit before = FitBump(start, l), after = FitBump(*got, l);
  EXPECT_NEAR(after.amplitude / before.amplitude, 2.0, 0.2);
  EXPECT_NEAR(after.radius / before.radius, 1.0, 0.005);
  EXPECT_EQ(FlippedFaces(start, *got), 0);
}

// Sharpening a needle's apex across its base turns the needle over: the service's result turns
// none, and its summary counts the vertices held back, as the core's Enhance does.
TEST(EnhanceServiceTest, TheSummaryCountsTheVerticesHeldBack) {
  auto server = StartServer();
  const Mesh start = FloatMesh(SphereWithNeedles(1e-5));
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), EnhanceSpec(3.0, 0.5), *EncodeDraco(start));
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(out->summary.flipped_normals(), 0);
  Mesh expected = start;
  EnhanceParams e;
  e.gain = 3.0;
  e.detail_scale = 0.5;
  Topology topo = BuildTopology(expected);
  const absl::StatusOr<EnhanceResult> r = Enhance(expected, topo, e);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_GE(r->held_back, 256);  // a vertex of each needle at least
  EXPECT_EQ(out->summary.parameters().enhance_held_back(), r->held_back);
}

TEST(EnhanceServiceTest, StrengthZeroHoldsAVertex) {
  auto server = StartServer();
  const Mesh start = FloatMesh(BumpySphere(4, 8, 0.01));
  std::vector<float> strength(start.positions.size(), 1.0f);
  for (size_t v = 0; v < strength.size(); ++v) strength[v] = start.positions[v].z > 0.3 ? 0.0f : 1.0f;
  Mesh with = start;
  with.properties.push_back({"keep", "float", std::vector<double>(strength.begin(), strength.end())});
  v1::JobSpec spec = EnhanceSpec(3.0, 1.0);
  spec.set_strength_attribute("keep");
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), spec, *EncodeDraco(with));
  ASSERT_TRUE(out.ok()) << out.status();
  const absl::StatusOr<Mesh> got = DecodeDraco(out->result);
  ASSERT_TRUE(got.ok());
  int64_t moved = 0;
  for (size_t v = 0; v < start.positions.size(); ++v) {
    if (strength[v] == 0.0f) {
      ASSERT_EQ(got->positions[v], start.positions[v]) << "held vertex " << v;
    } else {
      moved += !(got->positions[v] == start.positions[v]);
    }
  }
  EXPECT_GT(moved, static_cast<int64_t>(start.positions.size()) / 2);
}

// Noise is the finest detail: a noisy input is refused, naming its noise, or smoothed first.
TEST(EnhanceServiceTest, ANoisyInputIsRefusedOrSmoothedFirst) {
  auto server = StartServer();
  const Mesh noisy = FloatMesh(NoisySphere(4));
  const std::string draco = *EncodeDraco(noisy);
  ExpectStatus(Call(server->InProcessChannel(), EnhanceSpec(2.0, 0.0), draco).status(),
               absl::StatusCode::kFailedPrecondition, "the input is noisy");
  v1::JobSpec first = EnhanceSpec(2.0, 0.0);
  first.mutable_enhance()->set_smooth_first(true);
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), first, draco);
  ASSERT_TRUE(out.ok()) << out.status();
  const v1::EffectiveParameters& p = out->summary.parameters();
  EXPECT_GT(p.iterations_run(), 0u);
  EXPECT_GT(p.noise_estimate(), 0.0);
  EXPECT_TRUE(p.enhance().smooth_first());
  const absl::StatusOr<Mesh> got = DecodeDraco(out->result);
  ASSERT_TRUE(got.ok());
  EXPECT_LT(RadiusError(*got), 0.7 * RadiusError(noisy));
}

TEST(EnhanceServiceTest, BadSpecsAreRefusedNamingTheField) {
  auto server = StartServer();
  const std::string draco = *EncodeDraco(FloatMesh(BumpySphere(2, 8, 0.01)));
  auto refused = [&](const v1::JobSpec& spec, const std::string& words) {
    SCOPED_TRACE(words);
    ExpectStatus(Call(server->InProcessChannel(), spec, draco).status(), absl::StatusCode::kInvalidArgument, words);
  };
  for (double gain : {1.0, 0.5, 0.0, -2.0, 101.0, std::nan("")}) {
    refused(EnhanceSpec(gain, 0.0), "enhance.gain must be in (1, 100]");
  }
  refused(EnhanceSpec(2.0, -1.0), "enhance.detail_scale must be finite and >= 0");
  v1::JobSpec h = EnhanceSpec(2.0, 0.0);
  h.mutable_enhance()->set_detail_scale_h(std::nan(""));
  refused(h, "enhance.detail_scale_h must be finite");
  v1::JobSpec both = EnhanceSpec(2.0, 1.0);
  both.mutable_enhance()->set_detail_scale_h(8.0);
  refused(both, "enhance.detail_scale and enhance.detail_scale_h are both set");
  v1::JobSpec method = EnhanceSpec(2.0, 0.0);
  method.mutable_enhance()->set_method(static_cast<v1::EnhanceMethod>(9));
  refused(method, "enhance.method: unknown value 9");
  v1::JobSpec flow = EnhanceSpec(2.0, 0.0);
  flow.set_flow("laplacian");
  refused(flow, "flow does not apply to an enhancement job");
  v1::JobSpec iterations = EnhanceSpec(2.0, 0.0);
  iterations.set_iterations(3);
  refused(iterations, "iterations does not apply to an enhancement job");
  v1::JobSpec bound = EnhanceSpec(2.0, 0.0);
  bound.set_max_displacement_h(1.0);
  refused(bound, "max_displacement_h does not apply");
}

TEST(EnhanceServiceTest, ListFlowsListsTheFields) {
  auto server = StartServer();
  auto stub = v1::MeshSmoother::NewStub(server->InProcessChannel());
  grpc::ClientContext context;
  v1::ListFlowsResponse flows;
  ASSERT_TRUE(stub->ListFlows(&context, {}, &flows).ok());
  std::vector<std::string> names;
  for (const v1::ParameterInfo& p : flows.enhance_parameters()) names.push_back(p.name());
  EXPECT_EQ(names, (std::vector<std::string>{"enhance.gain", "enhance.detail_scale", "enhance.detail_scale_h",
                                             "enhance.smooth_first", "enhance.method"}));
  ASSERT_FALSE(flows.enhance_parameters().empty());
  const v1::ParameterInfo& gain = flows.enhance_parameters(0);
  EXPECT_EQ(gain.default_value(), 2.0);
  EXPECT_EQ(gain.min_value(), 1.0);
  EXPECT_TRUE(gain.min_exclusive());
  EXPECT_EQ(gain.max_value(), 100.0);
  // Not a flow: no flow of ListFlows is named for it.
  for (const v1::FlowInfo& f : flows.flows()) EXPECT_NE(f.name(), "enhance");
}

}  // namespace
}  // namespace meshsmooth
