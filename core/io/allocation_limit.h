// A bound on the largest block a third-party decoder may allocate on the thread that decodes
// one input. Draco's decoder sizes some buffers and loops from counts in the bitstream before it
// reads the data that should back them (e.g. the orientation bits of its portable texture-
// coordinate predictor: any int32, up to 2^31 bits and as many loop iterations, 5 s, from a
// 227-byte file), and it has no way to stop midway. Such a loop first allocates a buffer for
// its count, so a bound on any one allocation, set from the sizes the input declares, bounds
// both its memory and its time.
//
// This header only records the bound (a thread-local value). It is enforced by the replacement
// of the global operator new/delete in the base library (base/allocation_limit_new.cc), which
// the binaries, tests and fuzzers link; a program that links only meshsmooth::core keeps its
// own allocator, and there the bound has no effect (the decoder's declared-size checks in
// core/io/draco_checks.h still apply).
#pragma once

#include <cstdint>
#include <new>

namespace meshsmooth {

// Thrown by operator new inside a ScopedAllocationLimit for a block above the limit.
class AllocationLimitExceeded : public std::bad_alloc {
 public:
  const char* what() const noexcept override { return "a block larger than the input can account for"; }
};

// While alive, operator new on this thread throws AllocationLimitExceeded for any block above
// `largest` bytes (where base/ replaces operator new). Scopes nest; the innermost one counts.
class ScopedAllocationLimit {
 public:
  explicit ScopedAllocationLimit(int64_t largest);
  ~ScopedAllocationLimit();
  ScopedAllocationLimit(const ScopedAllocationLimit&) = delete;
  ScopedAllocationLimit& operator=(const ScopedAllocationLimit&) = delete;

 private:
  int64_t saved_;
};

// The largest block operator new may hand out on this thread: the innermost
// ScopedAllocationLimit's bound, or negative outside any.
int64_t LargestAllocationOnThisThread();

}  // namespace meshsmooth
