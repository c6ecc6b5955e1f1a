// --quantize-upload (client/upload_quantization.h): the bits chosen for a stated bound in closed
// form, every coordinate of the decoded upload within the bound it states, an upload smaller than
// the lossless one, and the refusals of a bad fraction or an input that goes as it is.
#include <cmath>
#include <filesystem>
#include <string>

#include "client/transfer.h"
#include "client/upload_quantization.h"
#include "core/io/draco_codec.h"
#include "core/io/mesh_io.h"
#include "gtest/gtest.h"

namespace meshsmooth::testing {
namespace {

// A grid of nx by ny vertices, `spacing` apart, two triangles a cell, with z from `height`.
template <typename Height>
Mesh Grid(int nx, int ny, double spacing, const Vec3& offset, const Height& height) {
  Mesh m;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double x = i * spacing, y = j * spacing;
      m.positions.push_back(Vec3{x, y, height(x, y)} + offset);
    }
  }
  for (int j = 0; j + 1 < ny; ++j) {
    for (int i = 0; i + 1 < nx; ++i) {
      const int32_t a = j * nx + i;
      m.triangles.push_back({a, a + 1, a + nx + 1});
      m.triangles.push_back({a, a + nx + 1, a + nx});
    }
  }
  return m;
}

class UploadQuantizationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("meshsmooth_quantize_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string Write(const Mesh& m, const std::string& name) {
    const std::string path = (dir_ / name).string();
    WriteOptions options;
    options.ply_double = true;
    EXPECT_TRUE(WriteMesh(path, m, options).ok());
    return path;
  }

  std::filesystem::path dir_;
};

// A plane 99.5 by 74.5 of 0.5 spacing: mean face edge 0.5 (2 + sqrt 2) / 3; a thousandth of it,
// 5.69e-4, takes 17 bits over the 99.5 extent (half a step 3.80e-4, plus 6 float32 units of
// 2^-17 at 99.5), where 16 bits would move a coordinate by up to 8.05e-4.
TEST_F(UploadQuantizationTest, BitsAndBoundInClosedForm) {
  const Mesh plane = Grid(200, 150, 0.5, {}, [](double, double) { return 0.0; });
  const client::UploadQuantization q = client::ChooseUploadQuantization(plane, 0.001);
  EXPECT_NEAR(q.mean_edge, 0.5 * (2.0 + std::sqrt(2.0)) / 3.0, 1e-12);
  EXPECT_EQ(q.bits, 17);
  const double rounding = 6.0 * std::ldexp(1.0, -17);
  EXPECT_DOUBLE_EQ(q.bound, 99.5 / 131071.0 / 2.0 + rounding);
  EXPECT_LE(q.bound, 0.001 * q.mean_edge);
  EXPECT_GT(99.5 / 65535.0 / 2.0 + rounding, 0.001 * q.mean_edge);
  EXPECT_EQ(client::DescribeUploadQuantization(q),
            "upload quantized to 17 bits: each coordinate within 0.000425342 of the input (0.001 of the mean edge "
            "0.569036)");
}

// Through the CLI's upload of a PLY file in double: every coordinate Draco decodes is within the
// stated bound of the coordinate as read, and the upload is smaller than the lossless one.
TEST_F(UploadQuantizationTest, DecodedUploadIsWithinTheStatedBoundAndSmaller) {
  const Mesh bumpy = Grid(160, 120, 0.25, {10.0, -20.0, 5.0}, [](double x, double y) {
    return 0.7 * std::sin(x / 3.0) * std::cos(y / 5.0) + 0.03 * std::sin(17.0 * x + 29.0 * y);
  });
  const std::string path = Write(bumpy, "bumpy.ply");
  for (const double fraction : {0.001, 0.01, 0.1}) {
    absl::StatusOr<client::Upload> quantized = client::PrepareUpload(path, false, false, {}, false, fraction);
    ASSERT_TRUE(quantized.ok()) << quantized.status();
    const client::UploadQuantization& q = quantized->quantization;
    ASSERT_GT(q.bits, 0) << fraction;
    EXPECT_LE(q.bound, fraction * q.mean_edge);
    absl::StatusOr<Mesh> decoded = DecodeDraco(quantized->draco, nullptr, false);
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    ASSERT_EQ(decoded->num_vertices(), bumpy.num_vertices());
    double largest = 0.0;
    for (int32_t v = 0; v < decoded->num_vertices(); ++v) {
      const Vec3 d = decoded->positions[v] - quantized->kept.positions[v];
      largest = std::max({largest, std::abs(d.x), std::abs(d.y), std::abs(d.z)});
    }
    EXPECT_LE(largest, q.bound) << fraction;
    EXPECT_GT(largest, 0.1 * q.bound) << fraction;  // quantized indeed, to about the bound
    absl::StatusOr<client::Upload> lossless = client::PrepareUpload(path, false);
    ASSERT_TRUE(lossless.ok());
    EXPECT_EQ(lossless->quantization.bits, 0);
    EXPECT_LT(quantized->draco.size(), 0.75 * lossless->draco.size())
        << fraction << ": " << quantized->draco.size() << " against " << lossless->draco.size();
  }
}

// A bound finer than float32 at the mesh's coordinates: the upload goes lossless and says so.
TEST_F(UploadQuantizationTest, BoundFinerThanFloat32GoesLossless) {
  const Mesh far = Grid(50, 50, 0.01, {1e5, 0.0, 0.0}, [](double, double) { return 0.0; });
  const client::UploadQuantization q = client::ChooseUploadQuantization(far, 0.1);
  EXPECT_EQ(q.bits, 0);
  EXPECT_NE(client::DescribeUploadQuantization(q).find("upload sent lossless"), std::string::npos);
}

TEST_F(UploadQuantizationTest, FractionIsParsedOrRefused) {
  EXPECT_EQ(*client::ParseUploadQuantization(""), client::kDefaultUploadQuantization);
  EXPECT_EQ(*client::ParseUploadQuantization("0.1"), 0.1);
  EXPECT_EQ(*client::ParseUploadQuantization("1e-4"), 1e-4);
  for (const char* bad : {"0", "-0.001", "nan", "inf", "0.2", "abc", "in.ply"}) {
    const absl::StatusOr<double> f = client::ParseUploadQuantization(bad);
    ASSERT_FALSE(f.ok()) << bad;
    EXPECT_EQ(f.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(f.status().message().find("--quantize-upload takes the bound as a fraction of the mean edge length"),
              std::string::npos)
        << f.status();
    EXPECT_NE(f.status().message().find(std::string("got '") + bad + "'"), std::string::npos) << f.status();
  }
}

TEST_F(UploadQuantizationTest, DracoInputIsRefused) {
  const std::string path = (dir_ / "plane.drc").string();
  ASSERT_TRUE(WriteMesh(path, Grid(10, 10, 1.0, {}, [](double, double) { return 0.0; })).ok());
  const absl::StatusOr<client::Upload> upload = client::PrepareUpload(path, true, false, {}, false, 0.001);
  ASSERT_FALSE(upload.ok());
  EXPECT_EQ(upload.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(upload.status().message().find("--quantize-upload"), std::string::npos) << upload.status();
}

}  // namespace
}  // namespace meshsmooth::testing
