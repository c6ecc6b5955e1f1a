// The local origin of georeferenced coordinates and the float32 resolution check
// (core/io/coordinates.h), and double coordinates through PLY.
#include "core/io/coordinates.h"

#include <string>

#include "core/io/mesh_io.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

TEST(CoordinatesTest, AMeshNearTheOriginKeepsItsCoordinates) {
  Mesh m = Icosphere(2);
  Translate(m.positions, {9000.0, -9998.5, 0.5});  // below 1e4 everywhere
  EXPECT_EQ(LocalOrigin(m.positions), Vec3{});
  EXPECT_EQ(LocalOrigin({}), Vec3{});
}

TEST(CoordinatesTest, AFarMeshGetsItsRoundedBoundingBoxCentre) {
  Mesh m = Icosphere(2);  // the bounding box is [-1, 1]^3
  Translate(m.positions, {512345.4, 5412345.6, -20000.5});
  EXPECT_EQ(LocalOrigin(m.positions), (Vec3{512345.0, 5412346.0, -20001.0}));
  // A non-finite vertex is ignored.
  m.positions.push_back({NAN, 1e9, 0.0});
  EXPECT_EQ(LocalOrigin(m.positions), (Vec3{512345.0, 5412346.0, -20001.0}));
}

TEST(CoordinatesTest, CoarseFloatCoordinatesAreNamedWithTheirStep) {
  const std::vector<Vec3> far = {{5412346.0, 0.0, 0.0}};
  EXPECT_EQ(Float32Spacing(far), 0.5);
  const std::optional<std::string> w = CoarseCoordinatesWarning(far, 0.01);
  ASSERT_TRUE(w.has_value());
  EXPECT_EQ(*w,
            "coordinates reach 5.41235e+06, where float32 steps by 0.5 (50 mean edges): the positions were rounded "
            "that coarsely before smoothing; send them relative to a local origin near the mesh (or give the "
            "meshsmooth CLI the .obj/.ply in full precision: it shifts them itself)");
  // 1 cm edges at 1 km: float32 steps by 2^-14 m, 0.6% of an edge.
  EXPECT_FALSE(CoarseCoordinatesWarning({{1000.0, 0.0, 0.0}}, 0.01).has_value());
  EXPECT_FALSE(CoarseCoordinatesWarning(far, 0.0).has_value());
}

TEST(CoordinatesTest, DoublePlyKeepsEveryBitAndSaysSo) {
  Mesh m = Icosphere(1);
  Translate(m.positions, {512345.123456789, 5412345.987654321, 0.1});
  for (bool binary : {true, false}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    WriteOptions o;
    o.ply_binary = binary;
    o.ply_double = true;
    absl::StatusOr<std::string> bytes = SerializeMesh(m, MeshFormat::kPly, o);
    ASSERT_TRUE(bytes.ok());
    EXPECT_NE(bytes->find("property double x\nproperty double y\nproperty double z\n"), std::string::npos);
    ReadInfo info;
    absl::StatusOr<Mesh> back = ParseMesh(*bytes, MeshFormat::kPly, &info);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_TRUE(info.double_positions);
    EXPECT_EQ(back->positions, m.positions);
  }
  absl::StatusOr<std::string> floats = SerializeMesh(m, MeshFormat::kPly);
  ASSERT_TRUE(floats.ok());
  ReadInfo info;
  ASSERT_TRUE(ParseMesh(*floats, MeshFormat::kPly, &info).ok());
  EXPECT_FALSE(info.double_positions);
}

}  // namespace
}  // namespace meshsmooth
