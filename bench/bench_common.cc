#include "bench/bench_common.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <utility>

#include "core/flows/catalogue.h"
#include "core/io/draco_codec.h"
#include "core/vec3.h"

namespace meshsmooth::bench {

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}

double StatusKb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) == 0) return std::atof(line.c_str() + std::strlen(key));
  }
  return -1.0;
}

FlowParams DefaultParams(std::string_view name) {
  FlowParams p;
  p.flow = ParseFlowName(name).value();
  return p;
}

std::string DracoUpload(Mesh mesh) {
  for (Vec3& p : mesh.positions) p = RoundToFloat(p);
  return *EncodeDraco(mesh);
}

}  // namespace meshsmooth::bench
