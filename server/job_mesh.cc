#include "server/job_mesh.h"

#include <algorithm>
#include <utility>
#include <variant>

#include "absl/strings/str_cat.h"
#include "core/vec3.h"

namespace meshsmooth::server {
namespace {

class DracoJobMesh final : public JobMesh {
 public:
  explicit DracoJobMesh(DracoMesh draco) : draco_(std::move(draco)) {}
  Mesh TakeWelded() override { return draco_.TakeWelded(); }
  absl::StatusOr<std::vector<float>> VertexValues(const std::string& name) const override {
    return draco_.VertexValues(name);
  }
  absl::Status CheckEncodable(const DracoOptions& options) const override { return draco_.CheckEncodable(options); }
  int64_t seam_points() const override { return draco_.seam_points(); }
  std::vector<Vec3> InputPositions() const override { return draco_.InputPositions(); }
  absl::StatusOr<std::string> Encode(const Mesh& smoothed, const DracoOptions& options,
                                     const std::vector<GenericAttribute>& extra, const StopToken& stop) override {
    return draco_.Encode(smoothed, options, extra, stop);
  }

 private:
  DracoMesh draco_;
};

// Each uploaded vertex is a point, at its float32 position (as Draco stores it).
std::vector<Vec3> Float32Points(const std::vector<Vec3>& positions) {
  std::vector<Vec3> points(positions.size());
  for (size_t v = 0; v < positions.size(); ++v) points[v] = RoundToFloat(positions[v]);
  return points;
}

class MemoryJobMesh final : public JobMesh {
 public:
  // The faces with every index in range (the others are not sent), welded over the points.
  // Faces all in range and no point welded: the upload's faces are the welded mesh's (lent).
  explicit MemoryJobMesh(MeshUpload upload) : upload_(std::move(upload)) {
    const int32_t n = static_cast<int32_t>(upload_.positions->size());
    std::vector<Triangle>& all = upload_.triangles;
    const bool in_range =
        std::none_of(all.begin(), all.end(), [n](const Triangle& t) { return IndexOutOfRange(t, n); });
    if (in_range) {
      weld_ = WeldMeshLending(Float32Points(*upload_.positions), all);
      faces_lent_ = weld_.point_to_vertex.empty();
    } else {
      std::vector<Triangle> faces;
      faces.reserve(all.size());
      for (const Triangle& t : all) {
        if (!IndexOutOfRange(t, n)) faces.push_back(t);
      }
      weld_ = WeldMesh(Float32Points(*upload_.positions), std::move(faces));
    }
    vertices_ = weld_.mesh.num_vertices();
  }
  Mesh TakeWelded() override { return std::exchange(weld_.mesh, Mesh{}); }
  absl::StatusOr<std::vector<float>> VertexValues(const std::string& name) const override {
    if (upload_.strength.empty()) return absl::NotFoundError(absl::StrCat("the mesh has no attribute '", name, "'"));
    return VertexMinimum(upload_.strength, weld_, vertices_);
  }
  absl::Status CheckEncodable(const DracoOptions& options) const override {
    if (options.quantization_bits == 0 && options.method == DracoMethod::kSequential) return absl::OkStatus();
    return absl::InvalidArgumentError(
        "a job on a mesh in memory hands back its positions unencoded: quantization and Edgebreaker are Draco "
        "encodings, for a job on Draco bytes");
  }
  int64_t seam_points() const override { return weld_.merged; }
  std::vector<Vec3> InputPositions() const override {
    // Every point its own vertex: each is its vertex's first point (no second copy of them).
    if (weld_.point_to_vertex.empty()) return Float32Points(*upload_.positions);
    return FirstPointPositions(Float32Points(*upload_.positions), weld_, vertices_);
  }
  absl::StatusOr<std::string> Encode(const Mesh& smoothed, const DracoOptions& options,
                                     const std::vector<GenericAttribute>& extra, const StopToken& stop) override {
    if (absl::Status s = CheckEncodable(options); !s.ok()) return s;
    if (absl::Status s = CheckPositionsEncodable(smoothed, options); !s.ok()) return s;
    for (const GenericAttribute& g : extra) {
      const size_t count = std::visit([](const auto& v) { return v.size(); }, g.values);
      if (count != smoothed.positions.size()) {
        return absl::InvalidArgumentError(absl::StrCat("attribute '", g.name, "' has ", count, " values for ",
                                                       smoothed.positions.size(), " vertices"));
      }
    }
    if (absl::Status s = stop.Check(); !s.ok()) return s;
    return std::string();
  }
  std::optional<MeshResult> TakeResult(Mesh smoothed, std::vector<GenericAttribute> attributes) override {
    MeshResult out{std::move(weld_), std::move(attributes), {}};
    out.smoothed.mesh = std::move(smoothed);
    // The job moves vertices, never faces: lent faces come back as they were lent. The result's
    // own faces are not needed past the job.
    out.upload_faces = faces_lent_ ? std::move(out.smoothed.mesh.triangles) : std::move(upload_.triangles);
    std::vector<Triangle>().swap(out.smoothed.mesh.triangles);
    return out;
  }

 private:
  MeshUpload upload_;
  bool faces_lent_ = false;  // upload_.triangles are the welded mesh's
  WeldedMesh weld_;
  int64_t vertices_ = 0;
};

}  // namespace

std::unique_ptr<JobMesh> JobMeshOf(DracoMesh draco) { return std::make_unique<DracoJobMesh>(std::move(draco)); }

std::unique_ptr<JobMesh> JobMeshInMemory(MeshUpload upload) {
  return std::make_unique<MemoryJobMesh>(std::move(upload));
}

}  // namespace meshsmooth::server
