#include "core/util/radix_sort.h"

#include <algorithm>
#include <utility>

namespace meshsmooth {

void RadixSortBits(std::vector<uint64_t>& keys, int low_bit, int digit_bits, int passes, int chunks) {
  const int64_t n = static_cast<int64_t>(keys.size());
  chunks = std::max(1, chunks);
  const size_t buckets = size_t{1} << digit_bits;
  const uint64_t mask = buckets - 1;
  // By value, and the bounds held in locals below: a store to a uint64_t key may alias an
  // int64_t, which would make the compiler recompute a bound (a division) per key.
  auto chunk_begin = [n, chunks](int c) { return n * c / chunks; };
  std::vector<uint64_t> tmp(keys.size());
  std::vector<uint32_t> count(static_cast<size_t>(chunks) * buckets);
  for (int pass = 0, shift = low_bit; pass < passes; ++pass, shift += digit_bits) {
#pragma omp parallel for schedule(static, 1) num_threads(chunks) if (chunks > 1)
    for (int c = 0; c < chunks; ++c) {
      uint32_t* h = &count[static_cast<size_t>(c) * buckets];
      std::fill(h, h + buckets, 0u);
      const uint64_t* const in = keys.data();
      for (int64_t i = chunk_begin(c), end = chunk_begin(c + 1); i < end; ++i) ++h[(in[i] >> shift) & mask];
    }
    uint32_t sum = 0;
    for (size_t b = 0; b < buckets; ++b) {
      for (int c = 0; c < chunks; ++c) sum += std::exchange(count[static_cast<size_t>(c) * buckets + b], sum);
    }
#pragma omp parallel for schedule(static, 1) num_threads(chunks) if (chunks > 1)
    for (int c = 0; c < chunks; ++c) {
      uint32_t* h = &count[static_cast<size_t>(c) * buckets];
      const uint64_t* const in = keys.data();
      uint64_t* const out = tmp.data();
      for (int64_t i = chunk_begin(c), end = chunk_begin(c + 1); i < end; ++i)
        out[h[(in[i] >> shift) & mask]++] = in[i];
    }
    keys.swap(tmp);
  }
}

}  // namespace meshsmooth
