#include "core/flows/lane_ring.h"

#include <algorithm>
#include <limits>

namespace meshsmooth::flows {

void BuildLaneRing(const Topology& topo, int width, int threads, std::vector<int32_t>& lane_ring,
                   std::vector<int64_t>& lane_offsets) {
  lane_ring.clear();
  lane_offsets.clear();
  const int32_t n = topo.num_vertices(), batches = n / width;
  if (batches == 0 || int64_t{n} * 3 > std::numeric_limits<int32_t>::max()) return;
  const int32_t* const offsets = topo.ring_offsets.data();
  const int32_t* const ring = topo.ring.data();
  auto valence = [&](int32_t v) { return offsets[v + 1] - offsets[v]; };
  lane_offsets.resize(static_cast<size_t>(batches) + 1);
  lane_offsets[0] = 0;
  for (int32_t b = 0; b < batches; ++b) {
    int32_t most = 0;
    for (int32_t v = b * width; v < (b + 1) * width; ++v) most = std::max(most, valence(v));
    lane_offsets[b + 1] = lane_offsets[b] + int64_t{most + 1} * width;
  }
  if (lane_offsets[batches] > 2 * int64_t{offsets[n]} + int64_t{batches} * width) {
    lane_offsets.clear();  // a few huge valences: the gathers are cheaper than the padding
    return;
  }
  lane_ring.resize(static_cast<size_t>(lane_offsets[batches]));
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (int32_t b = 0; b < batches; ++b) {
    int32_t* row = &lane_ring[static_cast<size_t>(lane_offsets[b])];
    const int32_t rows = static_cast<int32_t>((lane_offsets[b + 1] - lane_offsets[b]) / width);
    for (int32_t l = 0; l < width; ++l) {
      const int32_t v = b * width + l, begin = offsets[v], end = offsets[v + 1];
      row[l] = 3 * (begin < end ? ring[end - 1] : v);
      for (int32_t k = 0; k + 1 < rows; ++k) row[(k + 1) * width + l] = 3 * (begin + k < end ? ring[begin + k] : v);
    }
  }
}

}  // namespace meshsmooth::flows
