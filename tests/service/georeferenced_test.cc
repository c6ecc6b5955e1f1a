// A georeferenced scan through the CLI's upload and write-back (client/transfer.h) and the
// service: the mesh at survey coordinates (x ~ 5e5, y ~ 5e6 m) smooths as the same mesh at
// the origin, through OBJ and double PLY; a Draco upload whose float32 coordinates are too
// coarse is smoothed with a warning.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "client/transfer.h"
#include "core/io/coordinates.h"
#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth::testing {
namespace {

constexpr double kEdge = 0.01;  // 1 cm
constexpr int kAround = 300;
const double kRadius = kAround * kEdge / (2.0 * M_PI);  // 0.477 m
constexpr double kHeight = 1.5;
const Vec3 kSurvey{512345.25, 5412345.75, 231.5};  // UTM metres and an elevation

// A scanned column: an open cylinder of ~52k vertices with 1 cm edges, centred at the origin,
// with Gaussian noise of 0.2 mean edges along the normals.
Mesh NoisyColumn() {
  Mesh m = Cylinder(kRadius, kHeight, kAround, CylinderRings(kRadius, kHeight, kAround));
  Translate(m.positions, {0.0, 0.0, -0.5 * kHeight});
  AddNormalNoise(m, 0.2, 7);
  return m;
}

// Distance of each vertex (moved back by `offset`) to the clean cylinder's surface.
double RmsToCylinder(const Mesh& m, const Vec3& offset) {
  double sum = 0.0;
  for (const Vec3& q : m.positions) {
    const Vec3 p = q - offset;
    const double d = std::hypot(p.x, p.y) - kRadius;
    sum += d * d;
  }
  return std::sqrt(sum / m.num_vertices());
}

class GeoreferencedTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = StartServer();
    ASSERT_NE(server_, nullptr);
    dir_ = std::filesystem::temp_directory_path() /
           ("meshsmooth_georef_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // The CLI's path for `input` -> `output` with the default job; the result read back.
  Mesh SmoothFile(const std::string& input, const std::string& output, v1::Summary* summary = nullptr) {
    absl::StatusOr<client::Upload> upload = client::PrepareUpload(input);
    EXPECT_TRUE(upload.ok()) << upload.status();
    if (!upload.ok()) return {};
    absl::StatusOr<SmoothOutcome> outcome = Call(server_->InProcessChannel(), v1::JobSpec(), upload->draco);
    EXPECT_TRUE(outcome.ok()) << outcome.status();
    if (!outcome.ok()) return {};
    if (summary != nullptr) *summary = outcome->summary;
    const absl::Status written = client::WriteResult(*upload, outcome->result, output, false);
    EXPECT_TRUE(written.ok()) << written;
    absl::StatusOr<Mesh> back = ReadMesh(output);
    EXPECT_TRUE(back.ok()) << back.status();
    return back.ok() ? *back : Mesh{};
  }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  std::unique_ptr<server::Server> server_;
  std::filesystem::path dir_;
};

TEST_F(GeoreferencedTest, SurveyCoordinatesSmoothAsTheSameMeshAtTheOrigin) {
  const Mesh noisy = NoisyColumn();
  ASSERT_GE(noisy.num_vertices(), 50000);
  Mesh far = noisy;
  Translate(far.positions, kSurvey);
  ASSERT_TRUE(WriteMesh(Path("origin.obj"), noisy).ok());
  ASSERT_TRUE(WriteMesh(Path("survey.obj"), far).ok());
  WriteOptions doubles;
  doubles.ply_double = true;
  ASSERT_TRUE(WriteMesh(Path("survey.ply"), far, doubles).ok());

  const Mesh at_origin = SmoothFile(Path("origin.obj"), Path("origin-out.obj"));
  ASSERT_EQ(at_origin.num_vertices(), noisy.num_vertices());
  const double rms_noisy = RmsToCylinder(noisy, {});
  const double rms_origin = RmsToCylinder(at_origin, {});
  EXPECT_LT(rms_origin, 0.7 * rms_noisy);  // the job did smooth

  for (const char* format : {"obj", "ply"}) {
    SCOPED_TRACE(format);
    const std::string out = Path(std::string("survey-out.") + format);
    const Mesh smoothed = SmoothFile(Path(std::string("survey.") + format), out);
    ASSERT_EQ(smoothed.num_vertices(), noisy.num_vertices());
    ASSERT_EQ(smoothed.triangles, noisy.triangles);
    const double rms = RmsToCylinder(smoothed, kSurvey);
    EXPECT_LE(rms, 1.02 * rms_origin) << "origin " << rms_origin / kEdge << " h, survey " << rms / kEdge << " h";
    double worst = 0.0;
    for (int32_t v = 0; v < smoothed.num_vertices(); ++v) {
      worst = std::fmax(worst, Norm(smoothed.positions[v] - kSurvey - at_origin.positions[v]));
    }
    EXPECT_LE(worst, 0.01 * kEdge) << "largest difference " << worst / kEdge << " h";
    std::printf(
        "%s: RMS to the surface %.5f h (noisy %.5f h, at the origin %.5f h, ratio %.5f); largest "
        "difference from the job at the origin %.3g h\n",
        format, rms / kEdge, rms_noisy / kEdge, rms_origin / kEdge, rms / rms_origin, worst / kEdge);
  }
  // The PLY came in double and goes out double.
  absl::StatusOr<std::string> ply = ReadFileBytes(Path("survey-out.ply"));
  ASSERT_TRUE(ply.ok());
  EXPECT_NE(ply->find("property double x\nproperty double y\nproperty double z\n"), std::string::npos);
}

TEST_F(GeoreferencedTest, CoarseDracoCoordinatesAreSmoothedWithAWarning) {
  // Mean edge ~ 0.38 m; float32 steps by 2^-6 m at x = 2e5: 4% of an edge.
  Mesh far = Icosphere(4);
  for (Vec3& p : far.positions) p = p * 5.0 + Vec3{2e5, 0.0, 0.0};
  absl::StatusOr<std::string> coarse = EncodeDraco(far);
  ASSERT_TRUE(coarse.ok()) << coarse.status();
  absl::StatusOr<SmoothOutcome> outcome = Call(server_->InProcessChannel(), v1::JobSpec(), *coarse);
  ASSERT_TRUE(outcome.ok()) << outcome.status();
  ASSERT_EQ(outcome->summary.warnings_size(), 1);
  EXPECT_NE(outcome->summary.warnings(0).find("float32 steps by 0.0156 "), std::string::npos)
      << outcome->summary.warnings(0);
  EXPECT_NE(outcome->summary.warnings(0).find("local origin"), std::string::npos);

  // The same sphere near the origin: no warning.
  Mesh near = Icosphere(4);
  for (Vec3& p : near.positions) p = p * 5.0;
  absl::StatusOr<std::string> fine = EncodeDraco(near);
  ASSERT_TRUE(fine.ok());
  outcome = Call(server_->InProcessChannel(), v1::JobSpec(), *fine);
  ASSERT_TRUE(outcome.ok()) << outcome.status();
  EXPECT_EQ(outcome->summary.warnings_size(), 0);
}

}  // namespace
}  // namespace meshsmooth::testing
