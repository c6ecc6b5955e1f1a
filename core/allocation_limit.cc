#include "core/allocation_limit.h"

#include <cstdlib>

namespace meshsmooth {
namespace {

// The largest block operator new hands out on this thread; negative: no limit.
thread_local int64_t largest_block = -1;

void* Allocate(std::size_t n) {
  if (largest_block >= 0 && n > static_cast<uint64_t>(largest_block)) throw AllocationLimitExceeded();
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}

}  // namespace

ScopedAllocationLimit::ScopedAllocationLimit(int64_t largest) : saved_(largest_block) {
  largest_block = largest < 0 ? 0 : largest;
}

ScopedAllocationLimit::~ScopedAllocationLimit() { largest_block = saved_; }

}  // namespace meshsmooth

// The replaceable global allocation functions ([new.delete]); the standard library's nothrow
// forms call these, and its aligned forms use aligned_alloc and free, consistently.
void* operator new(std::size_t n) { return meshsmooth::Allocate(n); }
void* operator new[](std::size_t n) { return meshsmooth::Allocate(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
