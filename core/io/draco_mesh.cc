// DracoMesh: a decoded Draco mesh kept whole, its points welded into vertices for smoothing,
// and written back with new positions, fresh normals and any added attributes.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <utility>
#include <variant>

#include "absl/strings/str_cat.h"
#include "core/io/draco_checks.h"
#include "core/io/draco_codec.h"
#include "core/io/draco_convert.h"
#include "core/weld.h"

namespace meshsmooth {

struct DracoMesh::Impl {
  // Released after decoding for a bare upload (Bare()), made anew from the smoothed mesh to encode.
  std::unique_ptr<draco::Mesh> draco;
  // A bare upload's positions as decoded (x, y, z float32 a point), for InputPositions().
  std::vector<float> bare_points;
  int64_t points = 0;
  WeldedMesh weld;           // the mesh (taken by TakeWelded) and each point's vertex
  int64_t num_vertices = 0;  // of weld.mesh, also once it has been taken
  int32_t VertexOf(uint32_t p) const { return weld.VertexOf(p); }
  int64_t edgebreaker_drops = 0;  // vertices none of whose points Edgebreaker keeps

  // Counts the vertices Edgebreaker would drop.
  void CountEdgebreakerDrops();
  // The steps of Encode(): each vertex value of `g` written to every point of the vertex, as a
  // one-component GENERIC attribute named g.name that replaces any of that name (InvalidArgument
  // when `g` has not one value per vertex); the positions; the normals.
  absl::Status AddGeneric(const GenericAttribute& g, size_t vertices);
  void SetPositions(const std::vector<Vec3>& positions);
  void RecomputeNormals(const std::vector<Vec3>& positions);
};

// True for what the CLI uploads for most outputs: float32 positions and faces, nothing else, one
// point a vertex. Its Draco mesh is then the welded mesh's own positions and faces, which a job
// keeps: holding it through the run would cost 36 bytes a vertex.
bool Bare(const draco::Mesh& dm, const WeldedMesh& weld) {
  if (dm.num_attributes() != 1 || dm.GetMetadata() != nullptr || !weld.point_to_vertex.empty()) return false;
  const draco::PointAttribute* pos = dm.GetNamedAttribute(draco::GeometryAttribute::POSITION);
  return pos != nullptr && pos->data_type() == draco::DT_FLOAT32 && pos->num_components() == 3 &&
         weld.mesh.triangles.size() == dm.num_faces() &&
         static_cast<uint32_t>(weld.mesh.num_vertices()) == dm.num_points();
}

void DracoMesh::Impl::CountEdgebreakerDrops() {
  std::vector<uint8_t> kept(num_vertices, 0);
  const std::vector<uint8_t> used = PointsEdgebreakerKeeps(*draco);
  for (size_t p = 0; p < used.size(); ++p) kept[VertexOf(p)] |= used[p];
  edgebreaker_drops = std::count(kept.begin(), kept.end(), 0);
}

absl::Status DracoMesh::Impl::AddGeneric(const GenericAttribute& g, size_t vertices) {
  draco::Mesh& dm = *draco;
  const uint32_t n = dm.num_points();
  const size_t count = std::visit([](const auto& v) { return v.size(); }, g.values);
  if (count != vertices) {
    return absl::InvalidArgumentError(
        absl::StrCat("attribute '", g.name, "' has ", count, " values for ", vertices, " vertices"));
  }
  for (int id = NamedAttributeId(dm, g.name); id >= 0; id = NamedAttributeId(dm, g.name)) dm.DeleteAttribute(id);
  const bool bytes = std::holds_alternative<std::vector<uint8_t>>(g.values);
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::GENERIC, nullptr, 1, bytes ? draco::DT_UINT8 : draco::DT_FLOAT32, false,
          bytes ? 1 : sizeof(float), 0);
  const uint32_t fresh_id = UnusedAttributeUniqueId(dm);
  const int id = dm.AddAttribute(ga, /*identity_mapping=*/true, n);
  draco::PointAttribute* a = dm.attribute(id);
  a->set_unique_id(fresh_id);
  for (uint32_t p = 0; p < n; ++p) {
    const int32_t v = VertexOf(p);
    if (bytes) {
      a->SetAttributeValue(draco::AttributeValueIndex(p), &std::get<std::vector<uint8_t>>(g.values)[v]);
    } else {
      a->SetAttributeValue(draco::AttributeValueIndex(p), &std::get<std::vector<float>>(g.values)[v]);
    }
  }
  NameAttribute(dm, id, g.name);
  return absl::OkStatus();
}

void DracoMesh::Impl::SetPositions(const std::vector<Vec3>& positions) {
  draco::Mesh& dm = *draco;
  const uint32_t n = dm.num_points();
  draco::PointAttribute* pos = dm.attribute(dm.GetNamedAttributeId(draco::GeometryAttribute::POSITION));
  // A position attribute stored in another type (or with more components) is replaced by a
  // plain float32 xyz one with the same point mapping.
  if (pos->data_type() != draco::DT_FLOAT32 || pos->num_components() != 3) {
    draco::GeometryAttribute ga;
    ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
    auto fresh = std::make_unique<draco::PointAttribute>(ga);
    fresh->SetIdentityMapping();
    fresh->Reset(n);
    const int id = dm.GetNamedAttributeId(draco::GeometryAttribute::POSITION);
    dm.SetAttribute(id, std::move(fresh));
    pos = dm.attribute(id);
  }
  for (uint32_t p = 0; p < n; ++p) {
    const Vec3& q = positions[VertexOf(p)];
    const float v[3] = {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
    pos->SetAttributeValue(pos->mapped_index(draco::PointIndex(p)), v);
  }
}

void DracoMesh::Impl::RecomputeNormals(const std::vector<Vec3>& positions) {
  draco::Mesh& dm = *draco;
  const uint32_t n = dm.num_points();
  const int normal_id = dm.GetNamedAttributeId(draco::GeometryAttribute::NORMAL);
  if (normal_id < 0) return;
  draco::PointAttribute* nrm = dm.attribute(normal_id);
  if (nrm->data_type() != draco::DT_FLOAT32 || nrm->num_components() != 3) return;
  // Sum the area-weighted normals of each point's faces into the point's normal value.
  std::vector<Vec3> sum(nrm->size());
  for (uint32_t f = 0; f < dm.num_faces(); ++f) {
    const draco::Mesh::Face& face = dm.face(draco::FaceIndex(f));
    if (face[0].value() >= n || face[1].value() >= n || face[2].value() >= n) continue;
    const Vec3& a = positions[VertexOf(face[0].value())];
    const Vec3& b = positions[VertexOf(face[1].value())];
    const Vec3& c = positions[VertexOf(face[2].value())];
    const Vec3 fn = Cross(b - a, c - a);
    for (int k = 0; k < 3; ++k) {
      const uint32_t vi = nrm->mapped_index(face[k]).value();
      if (vi < sum.size()) sum[vi] += fn;
    }
  }
  for (size_t i = 0; i < sum.size(); ++i) {
    const double len = Norm(sum[i]);
    if (!(len > 0.0)) continue;  // keep the old normal where no face defines one
    const float v[3] = {static_cast<float>(sum[i].x / len), static_cast<float>(sum[i].y / len),
                        static_cast<float>(sum[i].z / len)};
    nrm->SetAttributeValue(draco::AttributeValueIndex(static_cast<uint32_t>(i)), v);
  }
}

DracoMesh::DracoMesh(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DracoMesh::DracoMesh(DracoMesh&&) noexcept = default;
DracoMesh& DracoMesh::operator=(DracoMesh&&) noexcept = default;
DracoMesh::~DracoMesh() = default;

absl::StatusOr<DracoMesh> DracoMesh::Decode(std::string_view bytes, const StopToken& stop, int64_t max_vertices) {
  // Draco's decoder runs as one call; the token is checked between the steps around it.
  absl::StatusOr<std::unique_ptr<draco::Mesh>> dm = DecodeToDraco(bytes, max_vertices);
  if (!dm.ok()) return dm.status();
  if (absl::Status s = stop.Check(); !s.ok()) return s;
  absl::StatusOr<Mesh> points = PointMesh(**dm);
  if (!points.ok()) return points.status();
  if (absl::Status s = stop.Check(); !s.ok()) return s;
  auto impl = std::make_unique<Impl>();
  impl->draco = std::move(dm).value();
  impl->weld = WeldMesh(points->positions, std::move(points->triangles));
  impl->num_vertices = impl->weld.mesh.num_vertices();
  if (absl::Status s = stop.Check(); !s.ok()) return s;
  impl->CountEdgebreakerDrops();
  impl->points = impl->draco->num_points();
  if (Bare(*impl->draco, impl->weld)) {
    impl->bare_points.resize(3 * static_cast<size_t>(impl->points));
    const draco::PointAttribute* pos = impl->draco->GetNamedAttribute(draco::GeometryAttribute::POSITION);
    for (uint32_t p = 0; p < impl->points; ++p) {
      pos->GetMappedValue(draco::PointIndex(p), &impl->bare_points[3 * static_cast<size_t>(p)]);
    }
    impl->draco.reset();
  }
  return DracoMesh(std::move(impl));
}

absl::Status DracoMesh::CheckEncodable(const DracoOptions& options) const {
  if (absl::Status s = CheckDracoOptions(options); !s.ok()) return s;
  if (options.method == DracoMethod::kEdgebreaker && impl_->edgebreaker_drops > 0) {
    return EdgebreakerDropsError(impl_->edgebreaker_drops);
  }
  return absl::OkStatus();
}

const Mesh& DracoMesh::welded() const { return impl_->weld.mesh; }
Mesh DracoMesh::TakeWelded() { return std::exchange(impl_->weld.mesh, Mesh{}); }
int64_t DracoMesh::num_points() const { return impl_->points; }

std::vector<Vec3> DracoMesh::InputPositions() const {
  if (impl_->draco == nullptr) {  // bare: one point a vertex
    const std::vector<float>& xyz = impl_->bare_points;
    std::vector<Vec3> positions(xyz.size() / 3);
    for (size_t v = 0; v < positions.size(); ++v) positions[v] = {xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2]};
    return positions;
  }
  // Decode() checked every point's position.
  return FirstPointPositions(PointPositions(*impl_->draco).value(), impl_->weld, impl_->num_vertices);
}
int64_t DracoMesh::seam_points() const { return impl_->weld.merged; }

absl::StatusOr<std::vector<float>> DracoMesh::VertexValues(std::string_view name) const {
  const std::string what = absl::StrCat("attribute '", std::string(name), "'");
  if (impl_->draco == nullptr) return absl::NotFoundError(absl::StrCat("the mesh has no ", what));  // bare
  const draco::Mesh& dm = *impl_->draco;
  const int id = NamedAttributeId(dm, name);
  if (id < 0) return absl::NotFoundError(absl::StrCat("the mesh has no ", what));
  const draco::PointAttribute& a = *dm.attribute(id);
  if (absl::Status s = CheckNumericValues(a, what); !s.ok()) return s;
  if (a.num_components() != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " has ", static_cast<int>(a.num_components()), " components a point; it needs one"));
  }
  std::vector<float> per_point(dm.num_points());
  for (uint32_t p = 0; p < dm.num_points(); ++p) {
    const draco::AttributeValueIndex avi = a.mapped_index(draco::PointIndex(p));
    if (avi.value() >= a.size() || !a.ConvertValue<float>(avi, 1, &per_point[p])) {
      return absl::InvalidArgumentError(absl::StrCat(what, " has no value for point ", p));
    }
  }
  return VertexMinimum(per_point, impl_->weld, impl_->num_vertices);
}

absl::StatusOr<std::string> DracoMesh::Encode(const Mesh& smoothed, const DracoOptions& options,
                                              const std::vector<GenericAttribute>& extra, const StopToken& stop) {
  if (static_cast<int64_t>(smoothed.positions.size()) != impl_->num_vertices) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected ", impl_->num_vertices, " positions, got ", smoothed.positions.size()));
  }
  if (absl::Status s = CheckEncodable(options); !s.ok()) return s;
  for (size_t v = 0; v < smoothed.positions.size(); ++v) {
    if (absl::Status s = CheckCoordinates(smoothed.positions[v], "vertex", static_cast<int64_t>(v)); !s.ok()) {
      return s;
    }
  }
  // A bare upload's Draco mesh again, from the smoothed positions and the faces, which the job
  // does not change; released once encoded.
  const bool bare = impl_->draco == nullptr;
  if (bare) impl_->draco = PositionsAndFacesMesh(smoothed);
  for (const GenericAttribute& g : extra) {
    if (absl::Status s = impl_->AddGeneric(g, smoothed.positions.size()); !s.ok()) {
      if (bare) impl_->draco.reset();
      return s;
    }
  }
  if (!bare) impl_->SetPositions(smoothed.positions);
  impl_->RecomputeNormals(smoothed.positions);
  if (absl::Status s = stop.Check(); !s.ok()) {  // Draco's encoder runs as one call
    if (bare) impl_->draco.reset();
    return s;
  }
  if (bare) return EncodeReleasing(std::move(impl_->draco), options);
  return EncodeWithOptions(*impl_->draco, options);
}

}  // namespace meshsmooth
