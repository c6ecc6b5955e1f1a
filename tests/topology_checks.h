// Checks of a mesh's validation report shared by the core tests.
#pragma once

#include <cstdint>

#include "core/topology.h"
#include "gtest/gtest.h"

namespace meshsmooth::testing {

// Whether `r` is of a closed manifold with Euler characteristic `euler`; says which part fails.
inline ::testing::AssertionResult IsClosedManifold(const ValidationReport& r, int64_t euler) {
  if (r.closed() && r.manifold() && r.euler_characteristic() == euler) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "closed " << r.closed() << ", manifold " << r.manifold()
                                       << ", Euler characteristic " << r.euler_characteristic() << " (expected "
                                       << euler << ")\n"
                                       << FormatReport(r);
}

}  // namespace meshsmooth::testing
