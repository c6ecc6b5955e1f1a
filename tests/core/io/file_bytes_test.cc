#include "core/io/file_bytes.h"

#include <filesystem>
#include <string>

#include "core/io/mesh_io.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

namespace fs = std::filesystem;

TEST(FileBytesTest, ReadsBackEveryByteWritten) {
  std::string bytes;
  for (int i = 0; i < 200000; ++i) bytes.push_back(static_cast<char>(i * 7919 % 256));  // NULs included, > 1 chunk
  const std::string path = (fs::path(::testing::TempDir()) / "file_bytes.bin").string();
  ASSERT_TRUE(WriteFileBytes(path, bytes).ok());
  absl::StatusOr<std::string> back = ReadFileBytes(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, bytes);
  ASSERT_TRUE(WriteFileBytes(path, "").ok());
  back = ReadFileBytes(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, "");
  fs::remove(path);
}

TEST(FileBytesTest, ErrorsNameThePathAndTheReason) {
  const absl::Status missing = ReadFileBytes("/nonexistent/dir/x.obj").status();
  EXPECT_EQ(missing.code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(missing.message(), "cannot open '/nonexistent/dir/x.obj': No such file or directory");
  const absl::Status dir = ReadFileBytes(::testing::TempDir()).status();
  EXPECT_FALSE(dir.ok());
  EXPECT_NE(dir.message().find("Is a directory"), absl::string_view::npos) << dir;
  // A mesh file goes through the same reader.
  const absl::Status mesh = ReadMesh("/nonexistent/dir/x.obj").status();
  EXPECT_EQ(mesh.code(), absl::StatusCode::kNotFound);
  EXPECT_NE(mesh.message().find("No such file or directory"), absl::string_view::npos) << mesh;
}

TEST(FileBytesTest, ReadsFilesThatReportNoSize) {
  absl::StatusOr<std::string> status = ReadFileBytes("/proc/self/status");
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_NE(status->find("VmRSS:"), std::string::npos);
}

TEST(FileBytesTest, TokenFilesLoseWhitespaceAtBothEnds) {
  const std::string path = (fs::path(::testing::TempDir()) / "token").string();
  for (const char* content : {"s3cret", "s3cret\n", "  s3cret \t\r\n", "\n\ns3cret\n\n"}) {
    ASSERT_TRUE(WriteFileBytes(path, content).ok());
    absl::StatusOr<std::string> token = ReadTokenFile(path);
    ASSERT_TRUE(token.ok()) << token.status();
    EXPECT_EQ(*token, "s3cret") << "file content '" << content << "'";
  }
  ASSERT_TRUE(WriteFileBytes(path, " \n\t\n").ok());
  const absl::Status blank = ReadTokenFile(path).status();
  EXPECT_EQ(blank.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(blank.message().find(path), absl::string_view::npos) << blank;
  fs::remove(path);
  const absl::Status missing = ReadTokenFile(path).status();
  EXPECT_EQ(missing.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(missing.message().find("No such file or directory"), absl::string_view::npos) << missing;
}

}  // namespace
}  // namespace meshsmooth
