// A bound on the largest block a third-party decoder may allocate on the thread that decodes
// one input. Draco's decoder sizes some buffers and loops from counts in the bitstream before it
// reads the data that should back them (e.g. the orientation bits of its portable texture-
// coordinate predictor: any int32, up to 2^31 bits and as many loop iterations, 5 s, from a
// 227-byte file), and it has no way to stop midway. Such a loop first allocates a buffer for
// its count, so a bound on any one allocation, set from the sizes the input declares, bounds
// both its memory and its time.
//
// The bound works through replacement of the global operator new/delete (allocation_limit.cc;
// malloc and free underneath): outside a ScopedAllocationLimit they behave as the standard
// ones. Under AddressSanitizer, blocks from new are then seen as malloc'd, so ASan no longer
// reports a new/free mismatch; every other check stays.
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
// `largest` bytes. Scopes nest; the innermost one counts.
class ScopedAllocationLimit {
 public:
  explicit ScopedAllocationLimit(int64_t largest);
  ~ScopedAllocationLimit();
  ScopedAllocationLimit(const ScopedAllocationLimit&) = delete;
  ScopedAllocationLimit& operator=(const ScopedAllocationLimit&) = delete;

 private:
  int64_t saved_;
};

}  // namespace meshsmooth
