// Implicit steps through the service (JobSpec.integration, theta): the result equals the core's
// bit for bit and the summary says how it ran; a flow without an implicit form, a job that would
// choose its flow, a theta out of range or without IMPLICIT, and an unknown enum value are
// refused naming the field; ListFlows lists both fields for the flows that have the form.
#include <string>

#include "core/flows/flow.h"
#include "core/io/draco_codec.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

TEST(ImplicitServiceTest, EqualsTheCore) {
  auto server = StartServer();
  ASSERT_TRUE(server);
  const Mesh mesh = FloatMesh(NoisySphere(3));
  const std::string draco = *EncodeDraco(mesh);
  v1::JobSpec spec = Spec("bilaplacian", 3);
  spec.set_step(4.0);
  spec.set_integration(v1::INTEGRATION_IMPLICIT);
  spec.set_theta(0.5);
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), spec, draco);
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_EQ(out->summary.parameters().integration(), v1::INTEGRATION_IMPLICIT);
  EXPECT_EQ(out->summary.parameters().theta(), 0.5);
  FlowParams p = Params("bilaplacian", 3, 4.0);
  p.integration = Integration::kImplicit;
  p.theta = 0.5;
  Mesh expected = mesh;
  ASSERT_TRUE(Smooth(expected, p).ok());
  const absl::StatusOr<Mesh> got = DecodeDraco(out->result);
  ASSERT_TRUE(got.ok());
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    ASSERT_EQ(got->positions[v], RoundToFloat(expected.positions[v])) << "vertex " << v;
  }
}

TEST(ImplicitServiceTest, BadSpecsAreRefusedWithAReason) {
  auto server = StartServer();
  const std::string draco = *EncodeDraco(FloatMesh(NoisySphere(2)));
  auto refused = [&](const v1::JobSpec& spec, const std::string& words) {
    ExpectStatus(Call(server->InProcessChannel(), spec, draco).status(), absl::StatusCode::kInvalidArgument, words);
  };
  v1::JobSpec median = Spec("median", 2);
  median.set_integration(v1::INTEGRATION_IMPLICIT);
  refused(median, "flow median has no implicit form");
  v1::JobSpec choosing;
  choosing.set_integration(v1::INTEGRATION_IMPLICIT);
  refused(choosing, "implicit integration needs a flow");
  v1::JobSpec theta = Spec("mcf", 2);
  theta.set_integration(v1::INTEGRATION_IMPLICIT);
  theta.set_theta(0.2);
  refused(theta, "theta must be in [0.5, 1]");
  v1::JobSpec explicit_theta = Spec("mcf", 2);
  explicit_theta.set_theta(0.5);
  refused(explicit_theta, "theta is for integration IMPLICIT only");
  v1::JobSpec unknown = Spec("mcf", 2);
  unknown.set_integration(static_cast<v1::Integration>(7));
  refused(unknown, "integration");
}

TEST(ImplicitServiceTest, ListFlowsListsTheFieldsForTheFlowsWithTheForm) {
  auto server = StartServer();
  auto stub = v1::MeshSmoother::NewStub(server->InProcessChannel());
  grpc::ClientContext context;
  v1::ListFlowsResponse flows;
  ASSERT_TRUE(stub->ListFlows(&context, {}, &flows).ok());
  for (const v1::FlowInfo& flow : flows.flows()) {
    int listed = 0;
    for (const v1::ParameterInfo& p : flow.parameters()) listed += p.name() == "integration" || p.name() == "theta";
    const bool has_form = flow.name() == "laplacian" || flow.name() == "bilaplacian" || flow.name() == "mcf";
    EXPECT_EQ(listed, has_form ? 2 : 0) << flow.name();
  }
}

}  // namespace
}  // namespace meshsmooth
