#include "core/io/allocation_limit.h"

namespace meshsmooth {
namespace {

// The largest block operator new hands out on this thread; negative: no limit.
thread_local int64_t largest_block = -1;

}  // namespace

ScopedAllocationLimit::ScopedAllocationLimit(int64_t largest) : saved_(largest_block) {
  largest_block = largest < 0 ? 0 : largest;
}

ScopedAllocationLimit::~ScopedAllocationLimit() { largest_block = saved_; }

int64_t LargestAllocationOnThisThread() { return largest_block; }

}  // namespace meshsmooth
