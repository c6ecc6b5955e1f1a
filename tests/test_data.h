// Locating ../shared/data for tests; a test that needs it skips when it is absent.
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

}  // namespace meshsmooth::testing

// Skips the current test when ../shared/data/<sub> does not exist.
#define MESHSMOOTH_REQUIRE_SHARED(sub)                                                         \
  do {                                                                                         \
    if (!std::filesystem::is_directory(::meshsmooth::testing::SharedData(sub))) {              \
      GTEST_SKIP() << "shared data folder absent: " << ::meshsmooth::testing::SharedData(sub); \
    }                                                                                          \
  } while (0)
