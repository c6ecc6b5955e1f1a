// libFuzzer target: one file reader (MESHSMOOTH_FUZZ_FORMAT, a MeshFormat enumerator; one
// binary per format, see CMakeLists.txt), then what the service and the CLI do with its mesh.
//
// Bytes -> ParseMesh. A refusal must be INVALID_ARGUMENT, or RESOURCE_EXHAUSTED for sizes
// beyond the limits (the rule of meshsmooth.v1: a Draco file that declares more Edgebreaker
// faces or vertices than the reader decodes). A mesh must hold:
//   - every index is -1 or in [0, INT32_MAX] (the readers map anything else to -1); STL's
//     welded soup, whose indices the reader makes, has every index in range;
//   - colours are absent or one per vertex;
//   - topology building and validation survive it: the report counts what the arrays hold,
//     the one-ring names only existing vertices and only usable faces are kept;
//   - written back in the same format and read again, it has the same vertices and faces
//     (positions rounded to float32 where the format stores float32).
// Any violation aborts, so libFuzzer keeps the input.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "core/attributes.h"
#include "core/io/draco_codec.h"
#include "core/io/mesh_io.h"
#include "core/topology.h"

namespace meshsmooth::fuzz {
namespace {

constexpr MeshFormat kFormat = MeshFormat::MESHSMOOTH_FUZZ_FORMAT;

void Check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "reader fuzz target: invariant violated: %s\n", what);
  std::abort();
}

void CheckTopology(const Mesh& mesh) {
  const int32_t n = mesh.num_vertices();
  int64_t out_of_range = 0, usable = 0;
  for (const Triangle& t : mesh.triangles) {
    bool in_range = true;
    for (int32_t i : t) {
      Check(i >= -1, "an index below -1");
      in_range = in_range && i >= 0 && i < n;
    }
    out_of_range += !in_range;
    usable += IsUsableTriangle(t, n);
    if (kFormat == MeshFormat::kStl) Check(in_range, "STL: an index out of range");
  }
  Check(mesh.colors.empty() || mesh.colors.size() == mesh.positions.size(), "colours but not one per vertex");

  ValidationReport report;
  const Topology topo = BuildTopology(mesh, &report);
  Check(report.vertices == n && report.faces == mesh.num_triangles(), "the report miscounts vertices or faces");
  Check(report.faces_out_of_range == out_of_range, "the report miscounts out-of-range faces");
  Check(report.faces - report.dropped_faces() == usable, "the report miscounts usable faces");
  Check(topo.num_vertices() == n && topo.ring_offsets.size() == static_cast<size_t>(n) + 1,
        "the topology has the wrong size");
  Check(topo.ring_offsets[0] == 0 && topo.ring_offsets[n] == static_cast<int32_t>(topo.ring.size()),
        "the one-ring offsets do not span the ring");
  for (int32_t v = 0; v < n; ++v) Check(topo.ring_offsets[v] <= topo.ring_offsets[v + 1], "offsets decrease");
  for (int32_t w : topo.ring) Check(w >= 0 && w < n, "the one-ring names a vertex that does not exist");
  Check(topo.faces.size() == static_cast<size_t>(usable), "the topology keeps the wrong faces");
  for (int32_t f : topo.faces) {
    Check(f >= 0 && f < mesh.num_triangles() && IsUsableTriangle(mesh.triangles[f], n),
          "the topology keeps an unusable face");
  }
}

void CheckAttributes(const Mesh& mesh) {
  for (const CornerAttribute* a : {&mesh.uvs, &mesh.normals}) {
    if (a->empty()) {
      Check(a->corners.empty() && a->values.empty(), "an empty attribute with values or corners");
      continue;
    }
    Check(a->values.size() % a->components == 0, "an attribute's table is not whole entries");
    Check(a->corners.size() == 3 * mesh.triangles.size(), "an attribute without 3 corners a triangle");
    for (int32_t e : a->corners) Check(e >= -1 && e < a->entries(), "a corner names an entry that does not exist");
  }
  for (const VertexProperty& p : mesh.properties) {
    Check(p.values.size() == mesh.positions.size(), "a vertex property without one value a vertex");
  }
  for (const ObjDirective& d : mesh.obj_directives) {
    Check(d.before_triangle >= 0 && d.before_triangle <= mesh.num_triangles(), "a directive past the triangles");
  }
  const CornerAttribute fresh = FreshNormals(mesh, mesh.normals);
  Check(fresh.corners.size() == 3 * mesh.triangles.size(), "fresh normals without 3 corners a triangle");
  if (mesh.num_vertices() == 0 || mesh.triangles.empty()) return;
  absl::StatusOr<std::string> draco = EncodeDraco(mesh);
  if (!draco.ok()) return;  // e.g. no face in range, or coordinates Draco cannot hold
  absl::StatusOr<Mesh> points = DecodeDraco(*draco);
  Check(points.ok(), "EncodeDraco wrote what DecodeDraco refuses");
  Check(points->num_vertices() >= mesh.num_vertices(), "EncodeDraco lost vertices");
  for (int32_t v = 0; v < mesh.num_vertices(); ++v) {
    Check(points->positions[v] == RoundToFloat(mesh.positions[v]), "EncodeDraco moved vertex i off point i");
  }
}

// Same value once stored as the format stores it (float32 for PLY, STL and Draco).
bool SameValue(double written, double read) {
  const bool as_float = kFormat != MeshFormat::kObj && kFormat != MeshFormat::kOff;
  const double want = as_float ? static_cast<double>(static_cast<float>(written)) : written;
  return want == read || (std::isnan(want) && std::isnan(read));
}

void CheckRoundTrip(const Mesh& mesh) {
  absl::StatusOr<std::string> bytes = SerializeMesh(mesh, kFormat);
  if (!bytes.ok()) {
    // Draco cannot hold a mesh without one in-range face.
    Check(kFormat == MeshFormat::kDraco && bytes.status().code() == absl::StatusCode::kInvalidArgument,
          "writing a mesh that was read failed");
    return;
  }
  absl::StatusOr<Mesh> back = ParseMesh(*bytes, kFormat);
  Check(back.ok(), "a mesh written back does not read again");
  if (kFormat == MeshFormat::kStl) {
    // A soup of the usable faces, welded again: nothing to compare index for index.
    int64_t usable = 0;
    for (const Triangle& t : mesh.triangles) usable += IsUsableTriangle(t, mesh.num_vertices());
    Check(back->num_triangles() == usable, "STL written back lost or gained faces");
    return;
  }
  Check(back->positions.size() == mesh.positions.size(), "written back, the vertex count changed");
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3 &a = mesh.positions[i], &b = back->positions[i];
    Check(SameValue(a.x, b.x) && SameValue(a.y, b.y) && SameValue(a.z, b.z), "written back, a position changed");
  }
  std::vector<Triangle> stored = mesh.triangles;
  if (kFormat == MeshFormat::kDraco) {  // Draco cannot store a face with an index out of range
    std::erase_if(stored, [n = mesh.num_vertices()](const Triangle& t) {
      return t[0] < 0 || t[0] >= n || t[1] < 0 || t[1] >= n || t[2] < 0 || t[2] >= n;
    });
  }
  Check(back->triangles == stored, "written back, the faces changed");
  Check(back->colors == mesh.colors, "written back, the colours changed");
  if (kFormat != MeshFormat::kObj && kFormat != MeshFormat::kPly) return;
  if (!mesh.uvs.empty()) {
    Check(back->uvs.components == 2 && back->uvs.corners.size() == mesh.uvs.corners.size(),
          "written back, the texture coordinates are gone");
    for (size_t c = 0; c < mesh.uvs.corners.size(); ++c) {
      const int32_t e = mesh.uvs.corners[c], f = back->uvs.corners[c];
      if (e < 0) continue;
      Check(f >= 0, "written back, a corner lost its texture coordinate");
      for (int j = 0; j < 2; ++j) {
        const double a = mesh.uvs.values[2 * e + j], b = back->uvs.values[2 * f + j];
        Check(a == b || (std::isnan(a) && std::isnan(b)), "written back, a texture coordinate changed");
      }
    }
  }
  if (kFormat == MeshFormat::kPly) {
    Check(back->properties.size() == mesh.properties.size(), "written back, vertex properties are gone");
  }
}

}  // namespace
}  // namespace meshsmooth::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace meshsmooth;
  absl::StatusOr<Mesh> mesh = ParseMesh(std::string_view(reinterpret_cast<const char*>(data), size), fuzz::kFormat);
  if (!mesh.ok()) {
    const absl::StatusCode code = mesh.status().code();
    fuzz::Check(code == absl::StatusCode::kInvalidArgument || code == absl::StatusCode::kResourceExhausted,
                "a refusal that is neither INVALID_ARGUMENT nor RESOURCE_EXHAUSTED");
    return 0;
  }
  fuzz::CheckTopology(*mesh);
  fuzz::CheckAttributes(*mesh);
  fuzz::CheckRoundTrip(*mesh);
  return 0;
}
