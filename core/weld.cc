#include "core/weld.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <numeric>
#include <utility>

#include "absl/hash/hash.h"

namespace meshsmooth {
namespace {

// Bit patterns of the coordinates with -0.0 turned into +0.0 (x + 0.0 does that).
std::array<uint64_t, 3> Bits(const Vec3& p) {
  const double c[3] = {p.x + 0.0, p.y + 0.0, p.z + 0.0};
  std::array<uint64_t, 3> b;
  std::memcpy(b.data(), c, sizeof c);
  return b;
}

bool HasNan(const Vec3& p) { return std::isnan(p.x) || std::isnan(p.y) || std::isnan(p.z); }

}  // namespace

Welded WeldPoints(const std::vector<Vec3>& points) {
  const size_t n = points.size();
  Welded w;
  w.point_to_vertex.resize(n);
  w.positions.reserve(n);
  // (hash, index) sorted by the hash's low 33 bits with a stable LSD radix sort, 11 bits a
  // pass: equal positions end up adjacent with their indices ascending, and other positions
  // share a key rarely (~n^2 / 2^34 pairs). Three passes over 2048 buckets instead of four
  // over 65536 (the whole hash), whose scattered writes missed the caches: 655k points
  // 15.4 / 13.7 -> 12.8 / 10.3 ms, 2.6M 108.8 / 111.4 -> 75.1 / 76.2 ms.
  constexpr int kDigitBits = 11, kKeyBits = 3 * kDigitBits;
  constexpr uint64_t kDigitMask = (uint64_t{1} << kDigitBits) - 1;
  std::vector<uint64_t> key(n), key_tmp(n);
  std::vector<uint32_t> idx(n), idx_tmp(n);
  const absl::Hash<std::array<uint64_t, 3>> hash;
  for (size_t i = 0; i < n; ++i) {
    key[i] = hash(Bits(points[i])) & ((uint64_t{1} << kKeyBits) - 1);
    idx[i] = static_cast<uint32_t>(i);
  }
  std::vector<uint32_t> count(size_t{1} << kDigitBits);
  for (int shift = 0; shift < kKeyBits; shift += kDigitBits) {
    std::fill(count.begin(), count.end(), 0u);
    for (uint64_t k : key) ++count[(k >> shift) & kDigitMask];
    uint32_t sum = 0;
    for (uint32_t& c : count) sum += std::exchange(c, sum);
    for (size_t i = 0; i < n; ++i) {
      const uint32_t at = count[(key[i] >> shift) & kDigitMask]++;
      key_tmp[at] = key[i];
      idx_tmp[at] = idx[i];
    }
    key.swap(key_tmp);
    idx.swap(idx_tmp);
  }
  std::vector<uint64_t>().swap(key_tmp);

  // rep[p]: the first point with exactly p's position. Inside a run of equal keys, sort by the
  // bit patterns (then index) and take the first of each group of equal positions.
  std::vector<uint32_t>& rep = idx_tmp;
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && key[j] == key[i]) ++j;
    if (j - i == 1) {
      rep[idx[i]] = idx[i];
    } else {
      std::sort(idx.begin() + static_cast<std::ptrdiff_t>(i), idx.begin() + static_cast<std::ptrdiff_t>(j),
                [&](uint32_t a, uint32_t b) {
                  const auto ka = Bits(points[a]), kb = Bits(points[b]);
                  return ka != kb ? ka < kb : a < b;
                });
      uint32_t first = idx[i];
      for (size_t k = i; k < j; ++k) {
        const uint32_t p = idx[k];
        if (k > i && (HasNan(points[p]) || Bits(points[p]) != Bits(points[first]))) first = p;
        rep[p] = HasNan(points[p]) ? p : first;
      }
    }
    i = j;
  }

  int32_t next = 0;
  for (size_t p = 0; p < n; ++p) {
    if (rep[p] == p) {
      w.point_to_vertex[p] = next++;
      w.positions.push_back(points[p]);
    } else {
      w.point_to_vertex[p] = w.point_to_vertex[rep[p]];
      ++w.merged;
    }
  }
  return w;
}

}  // namespace meshsmooth
