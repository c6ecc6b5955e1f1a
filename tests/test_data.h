// Locating ../shared/data for tests; a test that needs it skips when it is absent (fails under CI=true).
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include "absl/status/statusor.h"
#include "core/io/mesh_io.h"
#include "core/mesh.h"

#include "gtest/gtest.h"

namespace meshsmooth::testing {

inline std::filesystem::path SharedData(const std::string& sub) {
  return std::filesystem::path(MESHSMOOTH_SHARED_DIR) / "data" / sub;
}

// The mesh of an xz-compressed file of ../shared/data (e.g. "real/cone_noisy.obj.xz"),
// decompressed into `dir` with the xz program.
inline absl::StatusOr<Mesh> ReadSharedXz(const std::string& file, const std::filesystem::path& dir) {
  const std::filesystem::path xz = SharedData(file);
  const std::filesystem::path out = dir / xz.stem();
  const std::string cmd = "xz -dc '" + xz.string() + "' > '" + out.string() + "'";
  if (std::system(cmd.c_str()) != 0) return absl::InternalError(cmd + " failed");
  return ReadMesh(out.string());
}

// Under CI=true the shared folder must be there: a test that would skip for want of it fails
// instead (CI has ../shared, and a skipped test there passes without doing its work). A user's
// clone without ../shared skips, and ctest reports the skip.
inline bool SharedDataRequired() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string(ci) == "true";
}

}  // namespace meshsmooth::testing

// Skips the current test when `where` (a folder or file under ../shared/data) does not exist;
// fails it under CI=true.
#define MESHSMOOTH_REQUIRE_SHARED_PATH(where)                                     \
  do {                                                                            \
    const std::filesystem::path meshsmooth_shared_path = (where);                 \
    if (!std::filesystem::exists(meshsmooth_shared_path)) {                       \
      if (::meshsmooth::testing::SharedDataRequired()) {                          \
        FAIL() << "shared data absent under CI=true: " << meshsmooth_shared_path; \
      }                                                                           \
      GTEST_SKIP() << "shared data absent: " << meshsmooth_shared_path;           \
    }                                                                             \
  } while (0)

// Skips the current test when ../shared/data/<sub> does not exist; fails it under CI=true.
#define MESHSMOOTH_REQUIRE_SHARED(sub) MESHSMOOTH_REQUIRE_SHARED_PATH(::meshsmooth::testing::SharedData(sub))
