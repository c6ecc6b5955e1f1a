// The bound on displacement through the service (JobSpec.max_displacement, max_displacement_h):
// the result equals the core's bit for bit, stays within the bound, and the summary's count of
// vertices at the bound is the one a recount of the result finds; bad bounds are refused naming
// the field; ListFlows describes both fields.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/flows/catalogue.h"
#include "core/io/draco_codec.h"
#include "core/measure/metrics.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

// Vertices of `out` at least 0.999 `bound` from their place in `in`, counted on their own.
int64_t RecountAtBound(const Mesh& in, const Mesh& out, double bound) {
  int64_t count = 0;
  for (int32_t v = 0; v < in.num_vertices(); ++v) count += Norm(out.positions[v] - in.positions[v]) >= 0.999 * bound;
  return count;
}

TEST(DisplacementBoundServiceTest, EqualsTheCoreAndCountsTheVerticesAtTheBound) {
  auto server = StartServer();
  ASSERT_TRUE(server);
  Mesh noisy = Icosphere(3);
  AddRandomDirectionNoise(noisy, 0.3, 5);
  const Mesh mesh = FloatMesh(noisy);
  const std::string draco = *EncodeDraco(mesh);
  for (const std::string& flow : {std::string("laplacian"), std::string("bilateral_normal"), std::string()}) {
    SCOPED_TRACE(flow.empty() ? "the default job" : flow);
    v1::JobSpec spec = flow.empty() ? v1::JobSpec() : Spec(flow, 6);
    spec.set_max_displacement_h(0.15);
    absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), spec, draco);
    ASSERT_TRUE(out.ok()) << out.status();
    FlowParams p = flow.empty() ? FlowParams{} : Params(flow, 6);
    p.max_displacement_h = 0.15;
    Mesh expected = mesh;
    const absl::StatusOr<FlowResult> core = Smooth(expected, p);
    ASSERT_TRUE(core.ok());
    const double bound = core->displacement_bound;
    EXPECT_EQ(out->summary.parameters().max_displacement(), bound);
    const absl::StatusOr<Mesh> got = DecodeDraco(out->result);
    ASSERT_TRUE(got.ok());
    // float32 positions: within the bound but for their rounding (2^-24 of coordinates below 2).
    const double rounding = std::ldexp(1.0, -23);
    for (size_t v = 0; v < mesh.positions.size(); ++v) {
      ASSERT_EQ(got->positions[v], RoundToFloat(expected.positions[v])) << "vertex " << v;
      ASSERT_LE(Norm(got->positions[v] - mesh.positions[v]), bound + rounding) << "vertex " << v;
    }
    const int64_t at_bound = RecountAtBound(mesh, *got, bound);
    EXPECT_EQ(out->summary.vertices_at_bound(), at_bound);
    EXPECT_GT(at_bound, mesh.num_vertices() / 20);
    EXPECT_LE(out->summary.max_displacement(), bound * (1.0 + 1e-12));
  }
}

TEST(DisplacementBoundServiceTest, NoBoundReportsNone) {
  auto server = StartServer();
  const std::string draco = *EncodeDraco(FloatMesh(NoisySphere(2)));
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), Spec("taubin", 4), draco);
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(out->summary.parameters().max_displacement(), 0.0);
  EXPECT_EQ(out->summary.vertices_at_bound(), 0);
  EXPECT_GT(out->summary.max_displacement(), 0.0);
}

TEST(DisplacementBoundServiceTest, BadBoundsAreRefusedNamingTheField) {
  auto server = StartServer();
  const std::string draco = *EncodeDraco(FloatMesh(NoisySphere(2)));
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {-0.01, std::nan(""), inf, -inf}) {
    for (v1::JobSpec spec : {v1::JobSpec(), Spec("median", 2)}) {
      spec.set_max_displacement(bad);
      ExpectStatus(Call(server->InProcessChannel(), spec, draco).status(), absl::StatusCode::kInvalidArgument,
                   "max_displacement must be finite and >= 0");
      spec.set_max_displacement(0.0);
      spec.set_max_displacement_h(bad);
      ExpectStatus(Call(server->InProcessChannel(), spec, draco).status(), absl::StatusCode::kInvalidArgument,
                   "max_displacement_h must be finite and >= 0");
    }
  }
  v1::JobSpec both = Spec("median", 2);
  both.set_max_displacement(0.1);
  both.set_max_displacement_h(0.1);
  ExpectStatus(Call(server->InProcessChannel(), both, draco).status(), absl::StatusCode::kInvalidArgument,
               "max_displacement (0.1) and max_displacement_h (0.1) are both set");
}

TEST(DisplacementBoundServiceTest, ListFlowsDescribesTheFields) {
  auto server = StartServer();
  auto stub = v1::MeshSmoother::NewStub(server->InProcessChannel());
  grpc::ClientContext context;
  v1::ListFlowsResponse flows;
  ASSERT_TRUE(stub->ListFlows(&context, {}, &flows).ok());
  int described = 0;
  for (const v1::ParameterInfo& p : flows.common_parameters()) {
    if (p.name() != "max_displacement" && p.name() != "max_displacement_h") continue;
    ++described;
    EXPECT_EQ(p.default_value(), 0.0) << p.name();
    EXPECT_EQ(p.min_value(), 0.0) << p.name();
    EXPECT_FALSE(p.min_exclusive()) << p.name();
    EXPECT_NE(p.description().find("0 = no"), std::string::npos) << p.name() << ": " << p.description();
  }
  EXPECT_EQ(described, 2);
}

}  // namespace
}  // namespace meshsmooth
