#include "server/job_memory.h"

#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/flows/catalogue.h"

namespace meshsmooth::server {
namespace {

// "KEY: N kB" lines (/proc/meminfo, /proc/self/status): N * 1024 for KEY.
std::optional<int64_t> KibField(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string name, unit;
    int64_t kib = 0;
    if (fields >> name >> kib >> unit && name == key + ":" && unit == "kB" && kib >= 0) return kib * 1024;
  }
  return std::nullopt;
}

bool NamesNormalFilter(const JobParams& params) {
  return params.flow.flow.has_value() && KindOf(*params.flow.flow) == FlowKind::kNormalFilter;
}

}  // namespace

int64_t EstimateJobBytes(int64_t vertices, int64_t faces, const JobParams& params) {
  const JobMemoryModel& m = kJobMemory;
  int64_t bytes = m.fixed + m.per_vertex * vertices + m.per_face * faces;
  if (NamesNormalFilter(params)) bytes += m.normal_filter_per_face * faces;
  if (params.detect_features) bytes += m.features_per_vertex * vertices;
  return bytes;
}

std::string DescribeJobSize(int64_t vertices, int64_t faces, const JobParams& params) {
  const std::string flow =
      params.flow.flow.has_value() ? std::string(FlowName(*params.flow.flow)) : std::string("the default job");
  return absl::StrFormat("%d vertices, %d faces, %s%s", vertices, faces, flow,
                         params.detect_features ? " with ridges" : "");
}

std::string FormatBytes(int64_t bytes) {
  if (bytes >= 1'000'000'000) return absl::StrFormat("%.1f GB (%d bytes)", bytes / 1e9, bytes);
  if (bytes >= 1'000'000) return absl::StrFormat("%.0f MB (%d bytes)", bytes / 1e6, bytes);
  return absl::StrFormat("%d bytes", bytes);
}

std::optional<int64_t> MeminfoBytes(const std::string& field, const std::string& meminfo_path) {
  return KibField(meminfo_path, field);
}

int64_t ResidentBytes() { return KibField("/proc/self/status", "VmRSS").value_or(0); }

std::optional<int64_t> AvailableToThisProcess() {
  const std::optional<int64_t> available = MeminfoBytes("MemAvailable");
  if (!available.has_value()) return std::nullopt;
  return *available + ResidentBytes();
}

}  // namespace meshsmooth::server
