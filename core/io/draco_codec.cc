#include "core/io/draco_codec.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <tuple>
#include <utility>
#include <variant>

#include "absl/container/flat_hash_map.h"
#include "absl/strings/str_cat.h"
#include "core/io/allocation_limit.h"
#include "core/io/draco_checks.h"
#include "core/weld.h"
#include "draco/compression/decode.h"
#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"
#include "draco/metadata/geometry_metadata.h"

namespace meshsmooth {
namespace {

absl::StatusOr<std::string> EncodeWithOptions(const draco::Mesh& dm, const DracoOptions& options);

}  // namespace

namespace {

// True when every value is a float32 exactly (so a float32 attribute carries it bit for bit).
bool AllFloat(const std::vector<double>& values) {
  return std::all_of(values.begin(), values.end(),
                     [](double v) { return !std::isfinite(v) || static_cast<double>(static_cast<float>(v)) == v; });
}

// Adds an attribute of `components` values per point, float32 when that holds every value
// exactly and float64 otherwise; `value(p, out)` writes point p's values as doubles.
template <typename ValueOf>
int AddFloatAttribute(draco::Mesh& dm, draco::GeometryAttribute::Type type, int components, bool exact_float,
                      const ValueOf& value) {
  const uint32_t n = dm.num_points();
  draco::GeometryAttribute ga;
  const draco::DataType dt = exact_float ? draco::DT_FLOAT32 : draco::DT_FLOAT64;
  ga.Init(type, nullptr, components, dt, false, draco::DataTypeLength(dt) * components, 0);
  const int id = dm.AddAttribute(ga, /*identity_mapping=*/true, n);
  draco::PointAttribute* a = dm.attribute(id);
  double v[4];
  float f[4];
  for (uint32_t p = 0; p < n; ++p) {
    value(p, v);
    if (exact_float) {
      for (int c = 0; c < components; ++c) f[c] = static_cast<float>(v[c]);
      a->SetAttributeValue(draco::AttributeValueIndex(p), f);
    } else {
      a->SetAttributeValue(draco::AttributeValueIndex(p), v);
    }
  }
  return id;
}

}  // namespace

DracoPoints SplitAtSeams(const Mesh& mesh) {
  DracoPoints out;
  const int32_t n = mesh.num_vertices();
  const bool uv = mesh.uvs.corners.size() == 3 * mesh.triangles.size() && !mesh.uvs.empty();
  const bool nrm = mesh.normals.corners.size() == 3 * mesh.triangles.size() && !mesh.normals.empty();
  out.vertex.resize(n);
  for (int32_t v = 0; v < n; ++v) out.vertex[v] = v;
  out.uv.assign(uv ? n : 0, -1);
  out.normal.assign(nrm ? n : 0, -1);
  out.corners.resize(3 * mesh.triangles.size());
  std::vector<uint8_t> claimed(n, 0);
  // Corners whose values differ from their vertex's first ones become points of their own.
  absl::flat_hash_map<std::tuple<int32_t, int32_t, int32_t>, int32_t> extra;
  for (size_t c = 0; c < out.corners.size(); ++c) {
    const int32_t v = mesh.triangles[c / 3][c % 3];
    if (v < 0 || v >= n) {
      out.corners[c] = -1;
      continue;
    }
    const int32_t t = uv ? mesh.uvs.corners[c] : -1;
    const int32_t m = nrm ? mesh.normals.corners[c] : -1;
    if (!claimed[v]) {
      claimed[v] = 1;
      if (uv) out.uv[v] = t;
      if (nrm) out.normal[v] = m;
      out.corners[c] = v;
      continue;
    }
    if ((!uv || out.uv[v] == t) && (!nrm || out.normal[v] == m)) {
      out.corners[c] = v;
      continue;
    }
    auto [it, fresh] = extra.try_emplace({v, t, m}, static_cast<int32_t>(out.vertex.size()));
    if (fresh) {
      out.vertex.push_back(v);
      if (uv) out.uv.push_back(t);
      if (nrm) out.normal.push_back(m);
    }
    out.corners[c] = it->second;
  }
  return out;
}

absl::StatusOr<std::string> EncodeDraco(const Mesh& mesh, const DracoOptions& options) {
  const int32_t n = mesh.num_vertices();
  if (n == 0 || mesh.triangles.empty()) {
    return absl::InvalidArgumentError("cannot encode an empty mesh (no vertices or no faces)");
  }
  if (absl::Status s = CheckDracoOptions(options); !s.ok()) return s;
  for (int32_t i = 0; i < n; ++i) {
    if (absl::Status s = CheckCoordinates(mesh.positions[i], "vertex", i); !s.ok()) return s;
  }
  const bool attributes = mesh.has_attributes() || !mesh.colors.empty();
  const DracoPoints points = attributes ? SplitAtSeams(mesh) : DracoPoints{};
  const uint32_t num_points = attributes ? static_cast<uint32_t>(points.vertex.size()) : static_cast<uint32_t>(n);
  draco::Mesh dm;
  dm.set_num_points(num_points);
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
  const int att_id = dm.AddAttribute(ga, /*identity_mapping=*/true, num_points);
  draco::PointAttribute* positions = dm.attribute(att_id);
  for (uint32_t i = 0; i < num_points; ++i) {
    const Vec3& p = mesh.positions[attributes ? points.vertex[i] : static_cast<int32_t>(i)];
    const float v[3] = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
    positions->SetAttributeValue(draco::AttributeValueIndex(i), v);
  }
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    const Triangle& t = mesh.triangles[f];
    // Out-of-range faces cannot be stored (the validation report counts them).
    if (IndexOutOfRange(t, n)) continue;
    if (attributes) {
      dm.AddFace({draco::PointIndex(points.corners[3 * f]), draco::PointIndex(points.corners[3 * f + 1]),
                  draco::PointIndex(points.corners[3 * f + 2])});
    } else {
      dm.AddFace({draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
    }
  }
  if (attributes) {
    auto entry = [](const CornerAttribute& a, int32_t e, int components, double* v) {
      for (int c = 0; c < components; ++c) {
        v[c] = e >= 0 && e < a.entries() ? a.values[static_cast<size_t>(components) * e + c] : 0.0;
      }
    };
    if (!points.uv.empty()) {
      AddFloatAttribute(dm, draco::GeometryAttribute::TEX_COORD, 2, AllFloat(mesh.uvs.values),
                        [&](uint32_t p, double* v) { entry(mesh.uvs, points.uv[p], 2, v); });
    }
    if (!points.normal.empty()) {
      // Normals are recomputed from the smoothed positions: float32 is enough.
      AddFloatAttribute(dm, draco::GeometryAttribute::NORMAL, 3, true,
                        [&](uint32_t p, double* v) { entry(mesh.normals, points.normal[p], 3, v); });
    }
    if (mesh.colors.size() == static_cast<size_t>(n)) {
      draco::GeometryAttribute cg;
      cg.Init(draco::GeometryAttribute::COLOR, nullptr, 3, draco::DT_UINT8, true, 3, 0);
      draco::PointAttribute* a = dm.attribute(dm.AddAttribute(cg, /*identity_mapping=*/true, num_points));
      for (uint32_t p = 0; p < num_points; ++p) {
        const Rgb& c = mesh.colors[points.vertex[p]];
        const uint8_t rgb[3] = {c.r, c.g, c.b};
        a->SetAttributeValue(draco::AttributeValueIndex(p), rgb);
      }
    }
    for (const VertexProperty& prop : mesh.properties) {
      if (prop.values.size() != static_cast<size_t>(n)) continue;
      const int id = AddFloatAttribute(dm, draco::GeometryAttribute::GENERIC, 1, AllFloat(prop.values),
                                       [&](uint32_t p, double* v) { v[0] = prop.values[points.vertex[p]]; });
      auto metadata = std::make_unique<draco::AttributeMetadata>();
      metadata->AddEntryString("name", prop.name);
      dm.AddAttributeMetadata(id, std::move(metadata));
    }
  }
  if (options.method == DracoMethod::kEdgebreaker) {
    const std::vector<uint8_t> used = PointsEdgebreakerKeeps(dm);
    const int64_t dropped = std::count(used.begin(), used.end(), 0);
    if (dropped > 0) return EdgebreakerDropsError(dropped);
  }
  return EncodeWithOptions(dm, options);
}

int64_t LargestDracoDecodeBlock(size_t bytes, const std::optional<DeclaredSizes>& declared) {
  // Counts are below 2^34 (uint32 sums) and sizes below 2^40 in practice: no product overflows.
  if (declared.has_value()) {
    return kDracoDecodeFloorBytes + kDracoDecodeBytesPerElement * (declared->faces + declared->vertices);
  }
  return kDracoDecodeFloorBytes +
         kDracoDecodeBytesPerByte * static_cast<int64_t>(std::min<size_t>(bytes, size_t{1} << 40));
}

namespace {

// Decodes a Draco triangle mesh with clear errors; the sizes it declares are checked before
// Draco allocates for them (CheckDeclaredEdgebreakerSizes), its layout after (CheckDracoLayout).
absl::StatusOr<std::unique_ptr<draco::Mesh>> DecodeToDraco(std::string_view bytes, int64_t max_vertices) {
  if (bytes.empty()) return absl::InvalidArgumentError("empty Draco data");
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
  if (!type.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("not a Draco bitstream (corrupt header): ", type.status().error_msg_string()));
  }
  if (type.value() == draco::POINT_CLOUD) {
    return absl::InvalidArgumentError("the Draco data holds a point cloud, not a triangle mesh");
  }
  if (type.value() != draco::TRIANGULAR_MESH) {
    return absl::InvalidArgumentError("the Draco data holds no triangle mesh (invalid geometry type)");
  }
  absl::StatusOr<std::optional<DeclaredSizes>> declared = CheckDeclaredEdgebreakerSizes(bytes, max_vertices);
  if (!declared.ok()) return declared.status();
  std::unique_ptr<draco::Mesh> dm;
  const int64_t largest = LargestDracoDecodeBlock(bytes.size(), *declared);
  try {
    buffer.Init(bytes.data(), bytes.size());
    draco::Decoder decoder;
    draco::StatusOr<std::unique_ptr<draco::Mesh>> decoded = [&] {
      ScopedAllocationLimit limit(largest);
      return decoder.DecodeMeshFromBuffer(&buffer);
    }();
    if (!decoded.ok()) {
      return absl::InvalidArgumentError(
          // Draco itself cannot decode a mesh without faces, so "empty" is named here too.
          absl::StrCat("corrupt or empty Draco mesh: ", decoded.status().error_msg_string()));
    }
    dm = std::move(decoded).value();
  } catch (const AllocationLimitExceeded&) {
    return absl::InvalidArgumentError(absl::StrCat(
        "corrupt Draco mesh: its decoding asked for a block of memory above ", largest,
        " bytes, more than a valid encoding of ",
        declared->has_value() ? absl::StrCat((*declared)->faces, " faces and ", (*declared)->vertices, " vertices")
                              : absl::StrCat(bytes.size(), " bytes"),
        " needs"));
  } catch (const std::exception& e) {  // e.g. bad_alloc for absurd counts in corrupt data
    return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: ", e.what()));
  }
  if (dm == nullptr || dm->num_points() == 0 || dm->num_faces() == 0) {
    return absl::InvalidArgumentError("the Draco mesh is empty (no points or no faces)");
  }
  if (absl::Status s = CheckDracoLayout(*dm); !s.ok()) return s;
  return dm;
}

// The position of every point of `dm`, as doubles (InvalidArgument for a point without one or
// with a coordinate out of range).
absl::StatusOr<std::vector<Vec3>> PointPositions(const draco::Mesh& dm) {
  const draco::PointAttribute* pos = dm.GetNamedAttribute(draco::GeometryAttribute::POSITION);
  const uint32_t n = dm.num_points();
  std::vector<Vec3> positions(n);
  // Plain float32 xyz (what a lossless encoder writes) is read directly, one copy per point;
  // ConvertValue's per-value type switch gives the same doubles, slower (docs/decisions.md).
  const bool float_xyz = pos->data_type() == draco::DT_FLOAT32 && pos->num_components() == 3;
  for (uint32_t i = 0; i < n; ++i) {
    const draco::AttributeValueIndex avi = pos->mapped_index(draco::PointIndex(i));
    if (avi.value() >= pos->size()) {
      return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: no position for point ", i));
    }
    if (float_xyz) {
      float xyz[3];
      std::memcpy(xyz, pos->GetAddress(avi), sizeof xyz);
      positions[i] = {xyz[0], xyz[1], xyz[2]};
    } else {
      double xyz[3];
      if (!pos->ConvertValue<double>(avi, 3, xyz)) {
        return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: no position for point ", i));
      }
      positions[i] = {xyz[0], xyz[1], xyz[2]};
    }
    if (absl::Status s = CheckCoordinates(positions[i], "point", i); !s.ok()) return s;
  }
  return positions;
}

// Positions of every point, and faces over points.
absl::StatusOr<Mesh> PointMesh(const draco::Mesh& dm) {
  absl::StatusOr<std::vector<Vec3>> positions = PointPositions(dm);
  if (!positions.ok()) return positions.status();
  Mesh mesh;
  mesh.positions = *std::move(positions);
  mesh.triangles.resize(dm.num_faces());
  for (uint32_t f = 0; f < dm.num_faces(); ++f) {  // every index < n (CheckDracoLayout)
    const draco::Mesh::Face& face = dm.face(draco::FaceIndex(f));
    for (int c = 0; c < 3; ++c) mesh.triangles[f][c] = static_cast<int32_t>(face[c].value());
  }
  return mesh;
}

// The attribute whose metadata entry "name" is `name`, or -1.
int NamedAttributeId(const draco::Mesh& dm, std::string_view name) {
  for (int32_t i = 0; i < dm.num_attributes(); ++i) {
    const draco::AttributeMetadata* md = dm.GetAttributeMetadataByAttributeId(i);
    std::string value;
    if (md != nullptr && md->GetEntryString("name", &value) && value == name) return i;
  }
  return -1;
}

absl::StatusOr<std::string> EncodeWithOptions(const draco::Mesh& dm, const DracoOptions& options) {
  if (absl::Status s = CheckDracoOptions(options); !s.ok()) return s;
  // Draco's sequential decoder takes more than three points per face for corrupt data and
  // refuses the bytes: write none rather than a file that nothing can read.
  if (options.method == DracoMethod::kSequential && dm.num_points() > 3ull * dm.num_faces()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "Draco's sequential encoding cannot hold more than 3 points per face: ", dm.num_points(), " points, ",
        dm.num_faces(), " faces with every index in range (remove the unreferenced vertices)"));
  }
  draco::Encoder encoder;
  encoder.SetSpeedOptions(options.speed, options.speed);
  encoder.SetEncodingMethod(options.method == DracoMethod::kSequential ? draco::MESH_SEQUENTIAL_ENCODING
                                                                       : draco::MESH_EDGEBREAKER_ENCODING);
  if (options.quantization_bits > 0) {
    const draco::PointAttribute* positions = dm.GetNamedAttribute(draco::GeometryAttribute::POSITION);
    if (absl::Status s = CheckQuantizedExtent(*positions); !s.ok()) return s;
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, options.quantization_bits);
  }
  draco::EncoderBuffer out;
  draco::Status status;
  try {
    status = encoder.EncodeMeshToBuffer(dm, &out);
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError("out of memory in Draco's encoder");
  }
  if (!status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("Draco encoding failed: ", status.error_msg_string()));
  }
  return std::string(out.data(), out.size());
}

}  // namespace

namespace {

// The attributes of a decoded Draco mesh that a Mesh holds, per point (a point is a vertex of
// DecodeDraco's mesh): the first TEX_COORD (u, v), NORMAL (x, y, z), COLOR (r, g, b, as 0..255
// for integer types and 0..1 for float ones), and each one-component attribute named by the
// metadata entry "name" as a vertex property. The others are named in `dropped`.
void ReadAttributes(const draco::Mesh& dm, Mesh& mesh, std::vector<std::string>* dropped) {
  const uint32_t n = dm.num_points();
  auto per_point = [&](CornerAttribute& a, const draco::PointAttribute& pa, int components) {
    a.components = components;
    a.values.assign(static_cast<size_t>(components) * n, 0.0);
    double v[4] = {0, 0, 0, 0};
    for (uint32_t p = 0; p < n; ++p) {
      // Every mapped index is in range (CheckDracoLayout).
      pa.ConvertValue<double>(pa.mapped_index(draco::PointIndex(p)), components, v);
      for (int c = 0; c < components; ++c) a.values[static_cast<size_t>(components) * p + c] = v[c];
    }
    a.corners.resize(3 * mesh.triangles.size());
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) a.corners[3 * t + k] = mesh.triangles[t][k];
    }
  };
  for (int32_t i = 0; i < dm.num_attributes(); ++i) {
    const draco::PointAttribute& pa = *dm.attribute(i);
    const int components = pa.num_components();
    std::string name;
    const draco::AttributeMetadata* md = dm.GetAttributeMetadataByAttributeId(i);
    const bool named = md != nullptr && md->GetEntryString("name", &name);
    // Booleans (ConvertValue is undefined for corrupt ones) and unknown types are not read.
    const bool numeric = CheckNumericValues(pa, "").ok();
    switch (numeric ? pa.attribute_type() : draco::GeometryAttribute::INVALID) {
      case draco::GeometryAttribute::POSITION:
        continue;
      case draco::GeometryAttribute::INVALID:
        break;
      case draco::GeometryAttribute::TEX_COORD:
        if (mesh.uvs.empty() && components >= 2) {
          per_point(mesh.uvs, pa, 2);
          continue;
        }
        break;
      case draco::GeometryAttribute::NORMAL:
        if (mesh.normals.empty() && components == 3) {
          per_point(mesh.normals, pa, 3);
          continue;
        }
        break;
      case draco::GeometryAttribute::COLOR:
        if (mesh.colors.empty() && components >= 3) {
          // ConvertValue gives a normalized integer attribute as 0..1, like a float one.
          const bool unit =
              pa.normalized() || pa.data_type() == draco::DT_FLOAT32 || pa.data_type() == draco::DT_FLOAT64;
          mesh.colors.resize(n);
          double v[4] = {0, 0, 0, 0};
          for (uint32_t p = 0; p < n; ++p) {
            pa.ConvertValue<double>(pa.mapped_index(draco::PointIndex(p)), 3, v);
            uint8_t rgb[3];
            for (int c = 0; c < 3; ++c) {
              const double x = unit ? v[c] * 255.0 : v[c];
              rgb[c] = !(x > 0.0) ? 0 : x >= 255.0 ? 255 : static_cast<uint8_t>(std::lround(x));
            }
            mesh.colors[p] = {rgb[0], rgb[1], rgb[2]};
          }
          continue;
        }
        break;
      default:
        if (named && components == 1) {
          VertexProperty prop{name, pa.data_type() == draco::DT_FLOAT64 ? "double" : "float", std::vector<double>(n)};
          for (uint32_t p = 0; p < n; ++p) {
            pa.ConvertValue<double>(pa.mapped_index(draco::PointIndex(p)), 1, &prop.values[p]);
          }
          mesh.properties.push_back(std::move(prop));
          continue;
        }
        break;
    }
    if (dropped != nullptr) {
      dropped->push_back(absl::StrCat("Draco attribute ", i, " (", pa.TypeToString(pa.attribute_type()),
                                      named ? absl::StrCat(" '", name, "'") : "", ", ", components, " components)"));
    }
  }
}

}  // namespace

absl::StatusOr<std::unique_ptr<draco::Mesh>> DecodeDracoMesh(std::string_view bytes) {
  return DecodeToDraco(bytes, kMaxDracoVertices);
}

absl::StatusOr<Mesh> DecodeDraco(std::string_view bytes, std::vector<std::string>* dropped, bool attributes) {
  absl::StatusOr<std::unique_ptr<draco::Mesh>> dm = DecodeToDraco(bytes, kMaxDracoVertices);
  if (!dm.ok()) return dm.status();
  absl::StatusOr<Mesh> mesh = PointMesh(**dm);
  if (!mesh.ok()) return mesh.status();
  if (attributes) ReadAttributes(**dm, *mesh, dropped);
  return mesh;
}

struct DracoMesh::Impl {
  std::unique_ptr<draco::Mesh> draco;
  Mesh welded;
  int64_t num_vertices = 0;  // of welded, also once it has been taken
  // Per point, its vertex; empty when every point is its own vertex (no seam, the same order):
  // 4 bytes a vertex fewer at the job's peak.
  std::vector<int32_t> point_to_vertex;
  int32_t VertexOf(uint32_t p) const { return point_to_vertex.empty() ? static_cast<int32_t>(p) : point_to_vertex[p]; }
  int64_t seam_points = 0;
  int64_t edgebreaker_drops = 0;  // vertices none of whose points Edgebreaker keeps
};

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
  Welded welded = WeldPoints(points->positions);
  if (absl::Status s = stop.Check(); !s.ok()) return s;
  impl->welded.positions = std::move(welded.positions);
  impl->num_vertices = impl->welded.num_vertices();
  impl->point_to_vertex = std::move(welded.point_to_vertex);
  impl->seam_points = welded.merged;
  impl->welded.triangles = std::move(points->triangles);
  for (Triangle& t : impl->welded.triangles) {
    for (int32_t& v : t) v = impl->point_to_vertex[v];
  }
  std::vector<uint8_t> kept(impl->num_vertices, 0);
  const std::vector<uint8_t> used = PointsEdgebreakerKeeps(*impl->draco);
  for (size_t p = 0; p < used.size(); ++p) kept[impl->point_to_vertex[p]] |= used[p];
  impl->edgebreaker_drops = std::count(kept.begin(), kept.end(), 0);
  bool identity = impl->seam_points == 0;
  for (size_t p = 0; identity && p < impl->point_to_vertex.size(); ++p) {
    identity = impl->point_to_vertex[p] == static_cast<int32_t>(p);
  }
  if (identity) std::vector<int32_t>().swap(impl->point_to_vertex);
  return DracoMesh(std::move(impl));
}

absl::Status DracoMesh::CheckEncodable(const DracoOptions& options) const {
  if (absl::Status s = CheckDracoOptions(options); !s.ok()) return s;
  if (options.method == DracoMethod::kEdgebreaker && impl_->edgebreaker_drops > 0) {
    return EdgebreakerDropsError(impl_->edgebreaker_drops);
  }
  return absl::OkStatus();
}

const Mesh& DracoMesh::welded() const { return impl_->welded; }
Mesh DracoMesh::TakeWelded() { return std::exchange(impl_->welded, Mesh{}); }
int64_t DracoMesh::num_points() const { return impl_->draco->num_points(); }

std::vector<Vec3> DracoMesh::InputPositions() const {
  // Decode() checked every point's position. WeldPoints numbers the vertices in the order their
  // first points appear and gives each that point's position: a point whose vertex is the next
  // number is that first point.
  const std::vector<Vec3> points = PointPositions(*impl_->draco).value();
  std::vector<Vec3> positions;
  positions.reserve(impl_->num_vertices);
  for (size_t p = 0; p < points.size(); ++p) {
    if (impl_->VertexOf(p) == static_cast<int32_t>(positions.size())) positions.push_back(points[p]);
  }
  return positions;
}
int64_t DracoMesh::seam_points() const { return impl_->seam_points; }

absl::StatusOr<std::vector<float>> DecodeDracoAttribute(std::string_view bytes, std::string_view name) {
  absl::StatusOr<std::unique_ptr<draco::Mesh>> dm = DecodeToDraco(bytes, kMaxDracoVertices);
  if (!dm.ok()) return dm.status();
  if (absl::StatusOr<Mesh> points = PointMesh(**dm); !points.ok()) return points.status();  // the coordinates
  const int id = NamedAttributeId(**dm, name);
  if (id < 0)
    return absl::NotFoundError(absl::StrCat("the Draco mesh has no attribute named '", std::string(name), "'"));
  const draco::PointAttribute* a = (*dm)->attribute(id);
  const std::string what = absl::StrCat("attribute '", std::string(name), "'");
  if (absl::Status s = CheckNumericValues(*a, what); !s.ok()) return s;
  const uint32_t n = (*dm)->num_points();
  std::vector<float> values(n);
  for (uint32_t p = 0; p < n; ++p) {
    const draco::AttributeValueIndex avi = a->mapped_index(draco::PointIndex(p));
    if (avi.value() >= a->size() || !a->ConvertValue<float>(avi, 1, &values[p])) {
      return absl::InvalidArgumentError(
          absl::StrCat("corrupt Draco mesh: no '", std::string(name), "' value for point ", p));
    }
  }
  return values;
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
  draco::Mesh& dm = *impl_->draco;
  const uint32_t n = dm.num_points();
  for (const GenericAttribute& g : extra) {
    const size_t count = std::visit([](const auto& v) { return v.size(); }, g.values);
    if (count != smoothed.positions.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("attribute '", g.name, "' has ", count, " values for ", smoothed.positions.size(), " vertices"));
    }
    for (int id = NamedAttributeId(dm, g.name); id >= 0; id = NamedAttributeId(dm, g.name)) dm.DeleteAttribute(id);
    const bool bytes = std::holds_alternative<std::vector<uint8_t>>(g.values);
    draco::GeometryAttribute ga;
    ga.Init(draco::GeometryAttribute::GENERIC, nullptr, 1, bytes ? draco::DT_UINT8 : draco::DT_FLOAT32, false,
            bytes ? 1 : sizeof(float), 0);
    // Draco numbers a new attribute's unique id by its index, which after a deletion can be
    // the id of an attribute still present (or of metadata left behind); the metadata would
    // then name the wrong attribute. A fresh id above every id in use avoids that.
    uint32_t fresh_id = 0;
    for (int32_t i = 0; i < dm.num_attributes(); ++i) fresh_id = std::max(fresh_id, dm.attribute(i)->unique_id() + 1);
    if (const draco::GeometryMetadata* md = dm.GetMetadata()) {
      for (const auto& am : md->attribute_metadatas()) {
        fresh_id = std::max(fresh_id, static_cast<uint32_t>(am->att_unique_id()) + 1);
      }
    }
    const int id = dm.AddAttribute(ga, /*identity_mapping=*/true, n);
    draco::PointAttribute* a = dm.attribute(id);
    a->set_unique_id(fresh_id);
    for (uint32_t p = 0; p < n; ++p) {
      const int32_t v = impl_->VertexOf(p);
      if (bytes) {
        a->SetAttributeValue(draco::AttributeValueIndex(p), &std::get<std::vector<uint8_t>>(g.values)[v]);
      } else {
        a->SetAttributeValue(draco::AttributeValueIndex(p), &std::get<std::vector<float>>(g.values)[v]);
      }
    }
    auto metadata = std::make_unique<draco::AttributeMetadata>();
    metadata->AddEntryString("name", g.name);
    dm.AddAttributeMetadata(id, std::move(metadata));
  }
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
    const Vec3& q = smoothed.positions[impl_->VertexOf(p)];
    const float v[3] = {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
    pos->SetAttributeValue(pos->mapped_index(draco::PointIndex(p)), v);
  }
  const int normal_id = dm.GetNamedAttributeId(draco::GeometryAttribute::NORMAL);
  if (normal_id >= 0) {
    draco::PointAttribute* nrm = dm.attribute(normal_id);
    if (nrm->data_type() == draco::DT_FLOAT32 && nrm->num_components() == 3) {
      // Sum the area-weighted normals of each point's faces into the point's normal value.
      std::vector<Vec3> sum(nrm->size());
      for (uint32_t f = 0; f < dm.num_faces(); ++f) {
        const draco::Mesh::Face& face = dm.face(draco::FaceIndex(f));
        if (face[0].value() >= n || face[1].value() >= n || face[2].value() >= n) continue;
        const Vec3& a = smoothed.positions[impl_->VertexOf(face[0].value())];
        const Vec3& b = smoothed.positions[impl_->VertexOf(face[1].value())];
        const Vec3& c = smoothed.positions[impl_->VertexOf(face[2].value())];
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
  }
  if (absl::Status s = stop.Check(); !s.ok()) return s;  // Draco's encoder runs as one call
  return EncodeWithOptions(dm, options);
}

}  // namespace meshsmooth
