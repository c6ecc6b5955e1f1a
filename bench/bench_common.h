// What the benchmark tools share: the clock and its units, the median of repeated runs, a
// flow's default parameters by name, and a mesh as the service receives it.
#pragma once

#include <chrono>
#include <string>
#include <string_view>
#include <vector>

#include "core/flows/flow.h"
#include "core/mesh.h"

namespace meshsmooth::bench {

using Clock = std::chrono::steady_clock;

// Milliseconds from `a` to `b`.
inline double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Seconds from `a` to `b`.
inline double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// The median of `v` (the mean of the middle two for an even count); 0 when `v` is empty.
double Median(std::vector<double> v);

// The default parameters of the flow-table flow `name`, which must exist.
FlowParams DefaultParams(std::string_view name);

// A benchmark mesh and the name its rows give it.
struct NamedMesh {
  std::string name;
  Mesh mesh;
};

// The value of /proc/self/status's line starting with `key` ("VmHWM:", "VmRSS:"), in kB; -1 when
// there is none.
double StatusKb(const char* key);

// `mesh` as a client uploads it: positions rounded to float32, lossless sequential Draco.
std::string DracoUpload(Mesh mesh);

}  // namespace meshsmooth::bench
