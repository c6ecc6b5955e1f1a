// The replaceable global allocation functions ([new.delete]) with the bound of
// core/io/allocation_limit.h: outside a ScopedAllocationLimit they behave as the standard ones
// (malloc and free underneath). Process-wide, so it lives in the base library, which only the
// programs link. Under AddressSanitizer, blocks from new are then seen as malloc'd, so ASan does
// not report a new/free mismatch; every other check stays.
#include <cstdlib>
#include <new>

#include "core/io/allocation_limit.h"

namespace {

void* Allocate(std::size_t n) {
  const int64_t largest = meshsmooth::LargestAllocationOnThisThread();
  if (largest >= 0 && n > static_cast<uint64_t>(largest)) throw meshsmooth::AllocationLimitExceeded();
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}

}  // namespace

// Referenced by the link options of meshsmooth::base (base/CMakeLists.txt), so that the linker
// takes this file out of the archive even where another library (a sanitizer's runtime, linked
// first) already defines operator new: ours must be the one a program runs.
extern "C" const int meshsmooth_operator_new_anchor = 1;

// Plain and nothrow: a sanitizer's runtime replaces them all, so a nothrow new left to it would
// be paired with our delete. The aligned forms stay the library's (its aligned new and aligned
// delete pair with each other).
void* operator new(std::size_t n) { return Allocate(n); }
void* operator new[](std::size_t n) { return Allocate(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return Allocate(n);
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
