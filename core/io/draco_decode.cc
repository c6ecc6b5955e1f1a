// Draco bytes -> Mesh: Draco's decoder behind the checks of draco_checks.h, then the points'
// positions, the faces over them, and the attributes a Mesh holds.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/io/allocation_limit.h"
#include "core/io/draco_checks.h"
#include "core/io/draco_codec.h"
#include "core/io/draco_convert.h"
#include "draco/compression/decode.h"

namespace meshsmooth {
namespace {

// Values of `components` per point as a corner attribute: each corner names its point's entry.
void ReadPerPoint(const draco::PointAttribute& pa, int components, uint32_t n, const Mesh& mesh, CornerAttribute& a) {
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
}

// The first three components of a COLOR attribute as 0..255.
std::vector<Rgb> ReadColours(const draco::PointAttribute& pa, uint32_t n) {
  // ConvertValue gives a normalized integer attribute as 0..1, like a float one.
  const bool unit = pa.normalized() || pa.data_type() == draco::DT_FLOAT32 || pa.data_type() == draco::DT_FLOAT64;
  std::vector<Rgb> colors(n);
  double v[4] = {0, 0, 0, 0};
  for (uint32_t p = 0; p < n; ++p) {
    pa.ConvertValue<double>(pa.mapped_index(draco::PointIndex(p)), 3, v);
    uint8_t rgb[3];
    for (int c = 0; c < 3; ++c) {
      const double x = unit ? v[c] * 255.0 : v[c];
      rgb[c] = !(x > 0.0) ? 0 : x >= 255.0 ? 255 : static_cast<uint8_t>(std::lround(x));
    }
    colors[p] = {rgb[0], rgb[1], rgb[2]};
  }
  return colors;
}

// Reads attribute `pa` of `n` points into `mesh` when a Mesh holds it and `mesh` has none of
// its kind yet; `name` is its name (AttributeName) or null. False when it is not read.
bool ReadAttribute(const draco::PointAttribute& pa, const std::string* name, uint32_t n, Mesh& mesh) {
  const int components = pa.num_components();
  // Booleans (ConvertValue is undefined for corrupt ones) and unknown types are not read.
  const bool numeric = CheckNumericValues(pa, "").ok();
  switch (numeric ? pa.attribute_type() : draco::GeometryAttribute::INVALID) {
    case draco::GeometryAttribute::POSITION:
      return true;  // PointMesh() read them
    case draco::GeometryAttribute::INVALID:
      return false;
    case draco::GeometryAttribute::TEX_COORD:
      if (!mesh.uvs.empty() || components < 2) return false;
      ReadPerPoint(pa, 2, n, mesh, mesh.uvs);
      return true;
    case draco::GeometryAttribute::NORMAL:
      if (!mesh.normals.empty() || components != 3) return false;
      ReadPerPoint(pa, 3, n, mesh, mesh.normals);
      return true;
    case draco::GeometryAttribute::COLOR:
      if (!mesh.colors.empty() || components < 3) return false;
      mesh.colors = ReadColours(pa, n);
      return true;
    default: {
      if (name == nullptr || components != 1) return false;
      VertexProperty prop{*name, pa.data_type() == draco::DT_FLOAT64 ? "double" : "float", std::vector<double>(n)};
      for (uint32_t p = 0; p < n; ++p) {
        pa.ConvertValue<double>(pa.mapped_index(draco::PointIndex(p)), 1, &prop.values[p]);
      }
      mesh.properties.push_back(std::move(prop));
      return true;
    }
  }
}

// The attributes of a decoded Draco mesh that a Mesh holds, per point (a point is a vertex of
// DecodeDraco's mesh): the first TEX_COORD (u, v), NORMAL (x, y, z), COLOR (r, g, b, as 0..255
// for integer types and 0..1 for float ones), and each one-component attribute named by the
// metadata entry "name" as a vertex property. The others are named in `dropped`.
void ReadAttributes(const draco::Mesh& dm, Mesh& mesh, std::vector<std::string>* dropped) {
  for (int32_t i = 0; i < dm.num_attributes(); ++i) {
    const draco::PointAttribute& pa = *dm.attribute(i);
    std::string name;
    const bool named = AttributeName(dm, i, &name);
    if (ReadAttribute(pa, named ? &name : nullptr, dm.num_points(), mesh) || dropped == nullptr) continue;
    dropped->push_back(absl::StrCat("Draco attribute ", i, " (", pa.TypeToString(pa.attribute_type()),
                                    named ? absl::StrCat(" '", name, "'") : "", ", ", pa.num_components(),
                                    " components)"));
  }
}

// The error for data whose decoding asked Draco for a block above `largest` bytes.
absl::Status AboveLimitError(int64_t largest, size_t bytes, const std::optional<DeclaredSizes>& declared) {
  return absl::InvalidArgumentError(
      absl::StrCat("corrupt Draco mesh: its decoding asked for a block of memory above ", largest,
                   " bytes, more than a valid encoding of ",
                   declared.has_value() ? absl::StrCat(declared->faces, " faces and ", declared->vertices, " vertices")
                                        : absl::StrCat(bytes, " bytes"),
                   " needs"));
}

// InvalidArgument unless the bytes hold a triangle mesh, as Draco's header says.
absl::Status CheckGeometryType(std::string_view bytes) {
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
  return absl::OkStatus();
}

}  // namespace

int64_t LargestDracoDecodeBlock(size_t bytes, const std::optional<DeclaredSizes>& declared) {
  // Counts are below 2^34 (uint32 sums) and sizes below 2^40 in practice: no product overflows.
  if (declared.has_value()) {
    return kDracoDecodeFloorBytes + kDracoDecodeBytesPerElement * (declared->faces + declared->vertices);
  }
  return kDracoDecodeFloorBytes +
         kDracoDecodeBytesPerByte * static_cast<int64_t>(std::min<size_t>(bytes, size_t{1} << 40));
}

absl::StatusOr<std::unique_ptr<draco::Mesh>> DecodeToDraco(std::string_view bytes, int64_t max_vertices) {
  if (bytes.empty()) return absl::InvalidArgumentError("empty Draco data");
  if (absl::Status s = CheckGeometryType(bytes); !s.ok()) return s;
  absl::StatusOr<std::optional<DeclaredSizes>> declared = CheckDeclaredEdgebreakerSizes(bytes, max_vertices);
  if (!declared.ok()) return declared.status();
  std::unique_ptr<draco::Mesh> dm;
  const int64_t largest = LargestDracoDecodeBlock(bytes.size(), *declared);
  try {
    draco::DecoderBuffer buffer;
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
    return AboveLimitError(largest, bytes.size(), *declared);
  } catch (const std::exception& e) {  // e.g. bad_alloc for absurd counts in corrupt data
    return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: ", e.what()));
  }
  if (dm == nullptr || dm->num_points() == 0 || dm->num_faces() == 0) {
    return absl::InvalidArgumentError("the Draco mesh is empty (no points or no faces)");
  }
  if (absl::Status s = CheckDracoLayout(*dm); !s.ok()) return s;
  return dm;
}

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

}  // namespace meshsmooth
