// Internal to core: the one radix sort (the Morton order of Smooth(), the weld of points).
#pragma once

#include <cstdint>
#include <vector>

namespace meshsmooth {

// Sorts `keys` by their bits [low_bit, low_bit + passes * digit_bits), stably, with LSD radix
// passes of digit_bits each: keys equal in those bits keep their order, so a key that packs a
// sort key above an index comes out with equal sort keys in index order. The keys are split
// into `chunks` contiguous chunks (one per thread): each pass counts per chunk, takes bucket
// offsets bucket by bucket and chunk by chunk, and scatters each chunk in order, so the result
// does not depend on `chunks`.
void RadixSortBits(std::vector<uint64_t>& keys, int low_bit, int digit_bits, int passes, int chunks);

}  // namespace meshsmooth
