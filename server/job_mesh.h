// What a job reads its mesh from: Draco bytes decoded (the service), or a mesh handed over in
// memory (the CLI's local run) made into what the service decodes from its lossless upload.
// SmoothJob (smooth_job.h) runs the same steps on either.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/draco_codec.h"
#include "core/mesh.h"
#include "core/util/stop_token.h"
#include "core/weld.h"

namespace meshsmooth::server {

// A mesh handed to a job in memory instead of Draco bytes (the CLI's local run). The job smooths
// what the service decodes from the lossless sequential upload of the same mesh: the positions
// rounded to float32, coincident ones welded into one vertex (each uploaded vertex is a point,
// WeldMesh), the faces with an index out of range left out, a welded vertex's strength the
// smallest of its points'. The same code as the service's from there on.
struct MeshUpload {
  const std::vector<Vec3>* positions = nullptr;  // borrowed: they outlive the job
  // Handed over, and handed back in MeshResult::upload_faces when the job succeeds: where every
  // index is in range and no point is welded into another (a scan's usual case), they are the
  // welded mesh's own faces through the job rather than a copy beside it (WeldMeshLending).
  std::vector<Triangle> triangles;
  // JobSpec.strength_attribute's values (whatever the name), one per vertex; empty: none.
  std::vector<float> strength;
};

// What a job run on a MeshUpload hands back instead of the result's Draco bytes.
struct MeshResult {
  // smoothed.mesh: the welded vertices at their smoothed positions (double; the service sends
  // their float32), without its faces; smoothed.VertexOf(i): uploaded vertex i's welded vertex.
  WeldedMesh smoothed;
  std::vector<GenericAttribute> attributes;  // one value per welded vertex: the ridge labels when asked
  std::vector<Triangle> upload_faces;        // MeshUpload::triangles, handed back as they came
};

// The upload as a job's steps read it.
class JobMesh {
 public:
  virtual ~JobMesh() = default;
  // As DracoMesh's: the welded mesh, moved out; the values of the one-component attribute
  // `name` per welded vertex; whether the result can be written with `options`; the points
  // welded into earlier ones; the welded vertices' positions as uploaded, made anew.
  virtual Mesh TakeWelded() = 0;
  virtual absl::StatusOr<std::vector<float>> VertexValues(const std::string& name) const = 0;
  virtual absl::Status CheckEncodable(const DracoOptions& options) const = 0;
  virtual int64_t seam_points() const = 0;
  virtual std::vector<Vec3> InputPositions() const = 0;
  // The result's Draco bytes (DracoMesh::Encode); a mesh in memory checks what the encoder
  // would, with the same errors, and returns no bytes.
  virtual absl::StatusOr<std::string> Encode(const Mesh& smoothed, const DracoOptions& options,
                                             const std::vector<GenericAttribute>& extra, const StopToken& stop) = 0;
  // A mesh in memory: the result of the job, `smoothed` (the mesh TakeWelded gave, at its smoothed
  // positions) with its weld, which maps the uploaded vertices to the result's, and the upload's
  // faces handed back; nothing for Draco bytes.
  virtual std::optional<MeshResult> TakeResult(Mesh /*smoothed*/, std::vector<GenericAttribute> /*attributes*/) {
    return std::nullopt;
  }
};

// A decoded upload.
std::unique_ptr<JobMesh> JobMeshOf(DracoMesh draco);

// A MeshUpload: its faces with every index in range welded over its vertices at their float32
// positions. Only lossless sequential output is encodable (InvalidArgument for quantization or
// Edgebreaker: those are Draco's encodings of a result, for a job on Draco bytes).
std::unique_ptr<JobMesh> JobMeshInMemory(MeshUpload upload);

}  // namespace meshsmooth::server
