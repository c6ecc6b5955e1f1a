#include "bench/peak_memory.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <utility>
#include <vector>

#include "bench/bench_common.h"
#include "core/flows/flow.h"
#include "core/io/draco_codec.h"
#include "core/io/file_bytes.h"
#include "core/topology.h"

namespace meshsmooth::bench {
int PeakChild(const std::string& draco_path) {
  absl::StatusOr<std::string> bytes = ReadFileBytes(draco_path);
  if (!bytes.ok()) return 1;
  std::string draco = std::move(*bytes);
  { std::ofstream("/proc/self/clear_refs") << "5"; }  // resets VmHWM to the resident set
  const double base = StatusKb("VmRSS:");
  std::string upload = draco;  // the job's own copy of the upload
  std::string().swap(draco);
  absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(upload);
  if (!dm.ok()) return 1;
  std::string().swap(upload);
  Mesh mesh = dm->TakeWelded();
  Topology topo = BuildTopology(mesh);
  FlowParams p;
  p.flow = FlowId::kMedian;
  p.iterations = 5;
  if (!Smooth(mesh, topo, p).ok()) return 1;
  const std::vector<Vec3> input = dm->InputPositions();  // the job's, for the displacement, after the run
  absl::StatusOr<std::string> out = dm->Encode(mesh);
  if (!out.ok()) return 1;
  std::printf("%f\n", (StatusKb("VmHWM:") - base) * 1024.0 / mesh.num_vertices());
  return input.empty() ? 1 : 0;
}

double PeakBytesPerVertex(const Mesh& mesh, const std::string& self) {
  const std::string path = "/tmp/meshsmooth_bench_peak.drc";
  if (!WriteFileBytes(path, DracoUpload(mesh)).ok()) return -1.0;
  double value = -1.0;
  if (std::FILE* f = popen((self + " --peak-child " + path).c_str(), "r")) {
    if (std::fscanf(f, "%lf", &value) != 1) value = -1.0;
    pclose(f);
  }
  std::remove(path.c_str());
  return value;
}

}  // namespace meshsmooth::bench
