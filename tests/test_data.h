// Locating ../shared/data for tests; a test that needs it skips when it is absent.
#pragma once

#include <filesystem>
#include <string>

#include "gtest/gtest.h"

namespace meshsmooth::testing {

inline std::filesystem::path SharedData(const std::string& sub) {
  return std::filesystem::path(MESHSMOOTH_SHARED_DIR) / "data" / sub;
}

}  // namespace meshsmooth::testing

// Skips the current test when ../shared/data/<sub> does not exist.
#define MESHSMOOTH_REQUIRE_SHARED(sub)                                                         \
  do {                                                                                         \
    if (!std::filesystem::is_directory(::meshsmooth::testing::SharedData(sub))) {              \
      GTEST_SKIP() << "shared data folder absent: " << ::meshsmooth::testing::SharedData(sub); \
    }                                                                                          \
  } while (0)
