#include "core/flows/lane_batches.h"

#include <algorithm>

#include "core/flows/flow_kernel.h"

namespace meshsmooth::flows {

LaneBatches BuildLaneBatches(const Topology& topo, const uint8_t* role, int width, int threads) {
  LaneBatches out;
  const int32_t n = topo.num_vertices();
  if (n == 0) return out;  // 3n fits in int32: Smooth() refuses larger meshes (ValidateFlowParams)
  const int32_t* const offsets = topo.ring_offsets.data();
  const int32_t* const ring = topo.ring.data();
  auto valence = [&](int32_t v) { return offsets[v + 1] - offsets[v]; };
  const int32_t blocks = (n + kBlock - 1) / kBlock;

  // Each block's free vertices by valence (a counting sort, stable), then its batches.
  std::vector<int32_t> sorted(n);
  std::vector<int32_t> free_count(blocks), batch_count(blocks);
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (int32_t b = 0; b < blocks; ++b) {
    const int32_t begin = b * kBlock, end = std::min(n, begin + kBlock);
    int32_t most = 0, count = 0;
    for (int32_t v = begin; v < end; ++v) {
      if (role[v] == kFree) most = std::max(most, valence(v)), ++count;
    }
    std::vector<int32_t> start(static_cast<size_t>(most) + 2, 0);
    for (int32_t v = begin; v < end; ++v) {
      if (role[v] == kFree) ++start[valence(v) + 1];
    }
    for (int32_t k = 0; k <= most; ++k) start[k + 1] += start[k];
    for (int32_t v = begin; v < end; ++v) {
      if (role[v] == kFree) sorted[begin + start[valence(v)]++] = v;
    }
    free_count[b] = count;
    batch_count[b] = (count + width - 1) / width;
  }
  out.width = width;
  out.block_first.resize(static_cast<size_t>(blocks) + 1, 0);
  for (int32_t b = 0; b < blocks; ++b) out.block_first[b + 1] = out.block_first[b] + batch_count[b];
  const int32_t batches = out.block_first[blocks];
  out.lanes.resize(batches);
  out.offsets.resize(static_cast<size_t>(batches) + 1, 0);
  for (int32_t b = 0; b < blocks; ++b) {  // the largest valence of a batch is its last lane's
    for (int32_t j = 0; j < batch_count[b]; ++j) {
      const int32_t first = b * kBlock + j * width, lanes = std::min(width, free_count[b] - j * width);
      const int32_t batch = out.block_first[b] + j;
      out.lanes[batch] = lanes;
      out.offsets[batch + 1] = out.offsets[batch] + int64_t{valence(sorted[first + lanes - 1]) + 3} * width;
    }
  }
  if (out.offsets[batches] > 2 * int64_t{offsets[n]} + int64_t{batches} * 3 * width) return LaneBatches{};
  out.data.resize(static_cast<size_t>(out.offsets[batches]));
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (int32_t b = 0; b < blocks; ++b) {
    for (int32_t j = 0; j < batch_count[b]; ++j) {
      const int32_t batch = out.block_first[b] + j, first = b * kBlock + j * width;
      int32_t* const row = &out.data[static_cast<size_t>(out.offsets[batch])];
      const int32_t rows = static_cast<int32_t>((out.offsets[batch + 1] - out.offsets[batch]) / width);
      for (int32_t l = 0; l < width; ++l) {
        const int32_t v = sorted[first + (l < out.lanes[batch] ? l : 0)];
        const int32_t begin = offsets[v], end = offsets[v + 1];
        row[l] = v;
        row[width + l] = end - begin;
        row[2 * width + l] = 3 * (begin < end ? ring[end - 1] : v);
        for (int32_t k = 0; k + 3 < rows; ++k) row[(k + 3) * width + l] = 3 * (begin + k < end ? ring[begin + k] : v);
      }
    }
  }
  return out;
}

}  // namespace meshsmooth::flows
