// A batch's plan of files (client/batch_plan.h): which inputs, which output paths, and the
// collisions refused before any file is read.
#include "client/batch_plan.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace meshsmooth::client {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A fresh folder under the test's temporary directory, removed at the end.
class BatchPlanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("batch_plan_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Touch(const std::string& name) {
    const fs::path p = dir_ / name;
    fs::create_directories(p.parent_path());
    std::ofstream(p) << "x";
    return p.string();
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

TEST(BatchOutputPathTest, StemInTheFolderWithTheFormatOrTheInputsExtension) {
  EXPECT_EQ(BatchOutputPath("scans/a.ply", "out", ""), "out/a.ply");
  EXPECT_EQ(BatchOutputPath("scans/a.ply", "out/", ""), "out/a.ply");
  EXPECT_EQ(BatchOutputPath("scans/a.ply", "out", "obj"), "out/a.obj");
  EXPECT_EQ(BatchOutputPath("a.b.OBJ", "out", ""), "out/a.b.OBJ");  // the last extension only, as written
  EXPECT_EQ(BatchOutputPath("a.b.OBJ", "out", "drc"), "out/a.b.drc");
  EXPECT_EQ(BatchOutputPath("builtin:noisy-sphere", "out", ""), "out/noisy-sphere.ply");
  EXPECT_EQ(BatchOutputPath("builtin:noisy-sphere", "out", "stl"), "out/noisy-sphere.stl");
}

TEST_F(BatchPlanTest, TwoInputsWritingOneOutputAreRefusedNamingBoth) {
  absl::StatusOr<std::vector<BatchFile>> plan = PlanBatch({"a/x.ply", "b/x.ply"}, Path("out"), "");
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(plan.status().message(), HasSubstr("a/x.ply and b/x.ply"));
  EXPECT_THAT(plan.status().message(), HasSubstr(Path("out/x.ply")));
  // Two formats of one name meet once --format gives them the same extension.
  EXPECT_TRUE(PlanBatch({"x.ply", "x.obj"}, Path("out"), "").ok());
  plan = PlanBatch({"x.ply", "x.obj"}, Path("out"), "ply");
  ASSERT_FALSE(plan.ok());
  EXPECT_THAT(plan.status().message(), HasSubstr("x.ply and x.obj"));
  // The same input twice, however it is spelt.
  plan = PlanBatch({Path("in/a.ply"), Path("in/../in/a.ply")}, Path("out"), "");
  EXPECT_FALSE(plan.ok());
}

TEST_F(BatchPlanTest, AnOutputOverAnInputIsRefused) {
  const std::string a = Touch("in/a.ply"), b = Touch("in/b.ply");
  absl::StatusOr<std::vector<BatchFile>> plan = PlanBatch({a, b}, Path("in"), "");
  ASSERT_FALSE(plan.ok());
  EXPECT_THAT(plan.status().message(), HasSubstr("written over the input " + a));
  // Another input's result over it: other/a.obj with --format ply goes to in/a.ply, an input.
  const std::string obj = Touch("other/a.obj");
  plan = PlanBatch({obj, a}, Path("in"), "ply");
  ASSERT_FALSE(plan.ok());
  EXPECT_THAT(plan.status().message(), HasSubstr("the result of " + obj));
  plan = PlanBatch({a, b}, Path("in"), "obj");  // a new extension beside the inputs is fine
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_EQ((*plan)[1].output, Path("in/b.obj"));
}

TEST_F(BatchPlanTest, FoldersGiveTheirMeshFilesSortedAndGlobsTheirMatches) {
  Touch("scans/b.ply");
  Touch("scans/a.OBJ");
  Touch("scans/c.drc");
  Touch("scans/notes.txt");
  Touch("scans/a.mtl");
  Touch("scans/deeper/d.ply");  // a subfolder is not read
  absl::StatusOr<std::vector<std::string>> files = ExpandInputs({Path("scans")}, "");
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_THAT(*files, ElementsAre(Path("scans/a.OBJ"), Path("scans/b.ply"), Path("scans/c.drc")));
  files = ExpandInputs({Path("scans/*.ply"), "builtin:sphere", Path("scans/*.drc")}, "");
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_THAT(*files, ElementsAre(Path("scans/b.ply"), "builtin:sphere", Path("scans/c.drc")));
  // A file given by name is taken as it is, whatever its extension (reading it says what is wrong).
  files = ExpandInputs({Path("scans/notes.txt")}, "");
  ASSERT_TRUE(files.ok());
  EXPECT_THAT(*files, ElementsAre(Path("scans/notes.txt")));
}

TEST_F(BatchPlanTest, EmptyFoldersPatternsAndListsAreRefused) {
  fs::create_directories(dir_ / "empty");
  Touch("empty/readme.txt");
  absl::StatusOr<std::vector<std::string>> files = ExpandInputs({Path("empty")}, "");
  ASSERT_FALSE(files.ok());
  EXPECT_THAT(files.status().message(), HasSubstr("holds no mesh file"));
  files = ExpandInputs({Path("none/*.ply")}, "");
  ASSERT_FALSE(files.ok());
  EXPECT_THAT(files.status().message(), HasSubstr("matches no file"));
  EXPECT_FALSE(ExpandInputs({}, "").ok());
  EXPECT_FALSE(ExpandInputs({}, Path("missing.txt")).ok());
}

TEST_F(BatchPlanTest, AListGivesOneInputALineWithoutCommentsOrBlanks) {
  const std::string a = Touch("in/a.ply");
  Touch("more/b.obj");
  const std::string list = Path("list.txt");
  std::ofstream(list) << "# scans of Tuesday\n" << a << "\n\n   " << Path("more") << "  \nbuiltin:noisy-plane\n";
  absl::StatusOr<std::vector<std::string>> files = ExpandInputs({"builtin:sphere"}, list);
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_THAT(*files, ElementsAre("builtin:sphere", a, Path("more/b.obj"), "builtin:noisy-plane"));
}

TEST_F(BatchPlanTest, ABatchIsSeveralInputsAListAFolderAGlobOrAnOutputEndingInASlash) {
  const std::string a = Touch("a.ply");
  EXPECT_FALSE(IsBatch({a}, "", Path("out.ply")));
  EXPECT_FALSE(IsBatch({"builtin:sphere"}, "", Path("out.ply")));
  EXPECT_TRUE(IsBatch({a, a}, "", Path("out")));
  EXPECT_TRUE(IsBatch({}, Path("list.txt"), Path("out")));
  EXPECT_TRUE(IsBatch({dir_.string()}, "", Path("out")));
  EXPECT_TRUE(IsBatch({Path("*.ply")}, "", Path("out")));
  EXPECT_TRUE(IsBatch({a}, "", Path("new") + "/"));
  // One file to an existing folder stays a single run, which refuses it (a typo in -o).
  EXPECT_FALSE(IsBatch({a}, "", dir_.string()));
  // A file whose name holds a glob character is a file.
  const std::string odd = Touch("odd[1].ply");
  EXPECT_FALSE(IsBatch({odd}, "", Path("out.ply")));
}

TEST_F(BatchPlanTest, TheOutputFolderIsMadeButNeverAFile) {
  EXPECT_TRUE(PrepareOutputFolder(Path("new/deeper")).ok());
  EXPECT_TRUE(fs::is_directory(Path("new/deeper")));
  EXPECT_TRUE(PrepareOutputFolder(Path("new/deeper")).ok());  // again: it exists
  const std::string file = Touch("taken.ply");
  absl::Status s = PrepareOutputFolder(file);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("not a folder"));
  s = PrepareOutputFolder(Path("result.obj"));  // a single output's name
  EXPECT_THAT(s.message(), HasSubstr("names a mesh file"));
  EXPECT_FALSE(fs::exists(Path("result.obj")));
  EXPECT_TRUE(PrepareOutputFolder(Path("result.obj") + "/").ok());  // unless it ends in '/'
}

}  // namespace
}  // namespace meshsmooth::client
