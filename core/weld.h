// Internal to core: merges points with exactly equal positions into one vertex, numbered in
// order of first appearance (STL's triangle soup; Draco points split at attribute seams).
#pragma once

#include <cstdint>
#include <vector>

#include "absl/container/flat_hash_map.h"
#include "core/vec3.h"

namespace meshsmooth {

class PositionWelder {
 public:
  explicit PositionWelder(std::vector<Vec3>& positions, size_t expected = 0) : positions_(positions) {
    index_.reserve(expected);
  }

  // The vertex at `p`, appended to the positions when no earlier point had it.
  int32_t Add(const Vec3& p) {
    // +0.0 and -0.0 compare equal but hash differently: normalise before hashing.
    auto [it, inserted] = index_.try_emplace(Key{p.x + 0.0, p.y + 0.0, p.z + 0.0},
                                             static_cast<int32_t>(positions_.size()));
    if (inserted) {
      positions_.push_back(p);
    } else {
      ++merged_;
    }
    return it->second;
  }

  // Points merged into an earlier one so far.
  int64_t merged() const { return merged_; }

 private:
  struct Key {
    double x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
    template <typename H>
    friend H AbslHashValue(H h, const Key& k) {
      return H::combine(std::move(h), k.x, k.y, k.z);
    }
  };
  std::vector<Vec3>& positions_;
  absl::flat_hash_map<Key, int32_t> index_;
  int64_t merged_ = 0;
};

}  // namespace meshsmooth
