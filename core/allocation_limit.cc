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

// The replaceable global allocation functions ([new.delete]), plain and nothrow: a sanitizer's
// runtime replaces them all, so a nothrow new left to it would be paired with our delete. The
// aligned forms stay the library's (its aligned new and aligned delete pair with each other).
void* operator new(std::size_t n) { return meshsmooth::Allocate(n); }
void* operator new[](std::size_t n) { return meshsmooth::Allocate(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return meshsmooth::Allocate(n);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t& tag) noexcept { return operator new(n, tag); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
