#include "core/flows/reorder.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numeric>

#include "core/measure/metrics.h"
#include "core/util/radix_sort.h"

namespace meshsmooth {
namespace {

// Spreads the low 21 bits of x so that two zero bits follow each one (for Morton codes).
uint64_t Spread3(uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

// Reordering pays off once the positions outgrow the caches; below this it is skipped.
constexpr int32_t kReorderThreshold = 100000;
// Morton keys hold 25 bits of vertex index.
constexpr int32_t kReorderMaxVertices = 1 << 25;

// MortonOrderPaysOff(): neighbours further than kNearIndices from their vertex count as far;
// one in kLocalitySampleStride vertices is counted, in runs of kLocalitySampleRun consecutive
// ones (contiguous reads are cheaper than single scattered vertices). The shares of far
// neighbours of typical inputs are in docs/decisions.md ("Speed").
constexpr int32_t kNearIndices = 4096;
constexpr int32_t kLocalitySampleStride = 32;
constexpr int32_t kLocalitySampleRun = 64;
// Up to this share an order is as local as a Morton order would make it.
constexpr double kLocalFarShare = 0.03;
// Reordering repays itself after about this many iterations divided by the share: the middle
// of the break-even points measured on icospheres and the dragon (docs/decisions.md, "Speed").
constexpr double kRepayingFarShareIterations = 2.5;

}  // namespace

bool ReorderableSize(int32_t n) { return n >= kReorderThreshold && n <= kReorderMaxVertices; }

// Keys pack a 39-bit Morton code (13 bits per axis) above a 25-bit vertex index and are
// sorted by three 13-bit LSD radix passes (RadixSortBits, stable: ties keep index order).
std::vector<int32_t> MortonOrder(const std::vector<Vec3>& pos, int threads) {
  const int32_t n = static_cast<int32_t>(pos.size());
  if (n > kReorderMaxVertices) {  // the keys have no room for the index: keep the order
    std::vector<int32_t> identity(n);
    std::iota(identity.begin(), identity.end(), 0);
    return identity;
  }
  BoundingBox box;
  for (const Vec3& q : pos) {
    if (IsFinite(q)) box.Add(q);
  }
  const Vec3 lo = box.lo;
  const double extent = std::max(box.max_extent(), 1e-300);
  const double scale = 8191.0 / extent;
  auto cell = [&](double v, double origin) {
    const double c = (v - origin) * scale;
    return static_cast<uint64_t>(std::clamp(std::isfinite(c) ? c : 0.0, 0.0, 8191.0));
  };
  std::vector<uint64_t> keys(n);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int32_t i = 0; i < n; ++i) {
    const uint64_t code =
        Spread3(cell(pos[i].x, lo.x)) | Spread3(cell(pos[i].y, lo.y)) << 1 | Spread3(cell(pos[i].z, lo.z)) << 2;
    keys[i] = code << 25 | static_cast<uint64_t>(i);
  }
  const int chunks = threads > 1 && n >= kReorderThreshold ? threads : 1;
  RadixSortBits(keys, 25, 13, 3, chunks);
  std::vector<int32_t> order(n);
#pragma omp parallel for schedule(static) num_threads(chunks)
  for (int32_t i = 0; i < n; ++i) order[i] = static_cast<int32_t>(keys[i] & 0x1ffffff);
  return order;
}

bool MortonOrderPaysOff(const Topology& topo, int iterations) {
  const int32_t n = topo.num_vertices();
  if (!ReorderableSize(n)) return false;
  int64_t far = 0, sampled = 0;
  for (int32_t block = 0; block < n; block += kLocalitySampleStride * kLocalitySampleRun) {
    for (int32_t v = block; v < std::min(n, block + kLocalitySampleRun); ++v) {
      for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) {
        far += std::abs(topo.ring[k] - v) > kNearIndices;
      }
      sampled += topo.valence(v);
    }
  }
  if (sampled == 0) return false;
  const double share = static_cast<double>(far) / static_cast<double>(sampled);
  return share > kLocalFarShare && share * iterations >= kRepayingFarShareIterations;
}

// The loops below read the old arrays in the new order (or write them back so), scattered: they
// prefetch what vertex i + kAhead reads and the ring of vertex i + kAhead / 2 (whose offset is
// then in cache).
void Renumber(const std::vector<int32_t>& order, Mesh& mesh, Topology& topo, int threads) {
  constexpr int32_t kAhead = 16;
  const int32_t n = static_cast<int32_t>(order.size());
  std::vector<int32_t> rank(n);  // old -> new
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int32_t i = 0; i < n; ++i) rank[order[i]] = i;
  {
    std::vector<Vec3> positions(n);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int32_t i = 0; i < n; ++i) {
      if (i + kAhead < n) __builtin_prefetch(&mesh.positions[order[i + kAhead]]);
      positions[i] = mesh.positions[order[i]];
    }
    mesh.positions.swap(positions);
  }
  {
    std::vector<VertexKind> kind(n);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int32_t i = 0; i < n; ++i) kind[i] = topo.kind[order[i]];
    topo.kind.swap(kind);
  }
  {
    std::vector<int32_t> offsets(static_cast<size_t>(n) + 1);
    offsets[0] = 0;
    for (int32_t i = 0; i < n; ++i) {
      if (i + kAhead < n) __builtin_prefetch(&topo.ring_offsets[order[i + kAhead]]);
      offsets[i + 1] = offsets[i] + topo.valence(order[i]);
    }
    std::vector<int32_t> ring(topo.ring.size());
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int32_t i = 0; i < n; ++i) {
      if (i + kAhead < n) __builtin_prefetch(&topo.ring_offsets[order[i + kAhead]]);
      if (i + kAhead / 2 < n) __builtin_prefetch(&topo.ring[topo.ring_offsets[order[i + kAhead / 2]]]);
      const int32_t old = order[i];
      int32_t out = offsets[i];
      for (int32_t k = topo.ring_offsets[old]; k < topo.ring_offsets[old + 1]; ++k) ring[out++] = rank[topo.ring[k]];
    }
    topo.ring_offsets.swap(offsets);
    topo.ring.swap(ring);
  }
  const auto faces = static_cast<int64_t>(mesh.triangles.size());
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int64_t f = 0; f < faces; ++f) {
    for (int32_t& v : mesh.triangles[f]) {
      if (v >= 0 && v < n) v = rank[v];
    }
  }
}

void RenumberBack(const std::vector<int32_t>& order, Mesh& mesh, Topology& topo, int threads) {
  // Renumbering by the inverse permutation (old -> new, read as new -> old) is the way back.
  const int32_t n = static_cast<int32_t>(order.size());
  std::vector<int32_t> inverse(n);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int32_t i = 0; i < n; ++i) inverse[order[i]] = i;
  Renumber(inverse, mesh, topo, threads);
}

}  // namespace meshsmooth
