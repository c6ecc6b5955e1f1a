// A job's memory, estimated before it runs from its mesh's size, and the memory there is for it:
// what a server's admission (--max-job-bytes, admission.h) and the CLI's local run (the
// machine's available memory, or --max-memory) refuse a job by, naming both figures.
//
// The model: a fixed part + per vertex + per face, by what the job asks for. One model for both
// places a job runs (docs/performance.md, "Large meshes"): the local run's peak was 195-197 bytes
// a vertex on 10M- and 50M-vertex height fields, against 270 here for a mesh of two faces a
// vertex, with a margin for meshsmoothd's own peak (188 bytes a vertex on the 10M one for an
// upload of positions and faces alone; an upload with attributes keeps its decoded Draco mesh
// beside the welded one, about 36 more) and for the 19.4M one's copy into Morton order (237
// locally, 251 in meshsmoothd: docs/deployment.md, "Large meshes"); the normal-filtering flows from
// docs/deployment.md's "Memory" table (904-1,010 bytes a vertex on the dragon). The estimate is
// meant to be reached by no run of that kind, not to match one. Counts are the mesh's as it
// reaches the job: Draco's points (the upload's head, DracoDeclaredCounts: the points split at
// seams, at least the vertices welded from them) or the vertices handed over in memory.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "server/convert.h"

namespace meshsmooth::server {

struct JobMemoryModel {
  int64_t fixed = int64_t{64} << 20;  // the process's own and the job's small buffers
  // Every job: the mesh, its weld, topology, the Morton order, a flow's buffers, the metrics
  // and the input's positions for the displacement, beside the caller's own copy of the mesh.
  int64_t per_vertex = 190;
  int64_t per_face = 40;
  // A normal-filtering flow (bilateral_normal, guided_normal) named by the job: its face graph
  // and a dozen per-face arrays.
  int64_t normal_filter_per_face = 380;
  int64_t features_per_vertex = 60;  // ridges and ravines asked for: curvatures, labels
};
inline constexpr JobMemoryModel kJobMemory{};

// Bytes a job of `params` on a mesh of `vertices` and `faces` needs at its peak, by kJobMemory.
// A default job (no flow named) is estimated as the flow it chooses on large meshes,
// bilaplacian; when it chooses bilateral_normal it needs the normal-filtering figure.
int64_t EstimateJobBytes(int64_t vertices, int64_t faces, const JobParams& params);

// The estimate's terms, for a message: "N vertices, F faces, FLOW".
std::string DescribeJobSize(int64_t vertices, int64_t faces, const JobParams& params);

// `bytes` for a person and exactly: "812 MB (811514880 bytes)", "14.2 GB (14200000000 bytes)"
// (powers of 1000), "1000 bytes".
std::string FormatBytes(int64_t bytes);

// A field of /proc/meminfo ("MemAvailable", "MemTotal") in bytes; nullopt when it cannot be read.
std::optional<int64_t> MeminfoBytes(const std::string& field, const std::string& meminfo_path = "/proc/meminfo");

// This process's resident bytes (VmRSS in /proc/self/status); 0 when it cannot be read.
int64_t ResidentBytes();

// The memory a job started in this process now may take: MemAvailable plus what this process
// already holds (its mesh, read before the job, is part of the estimate); nullopt when
// /proc/meminfo cannot be read.
std::optional<int64_t> AvailableToThisProcess();

}  // namespace meshsmooth::server
