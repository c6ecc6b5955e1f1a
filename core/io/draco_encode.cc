// Mesh -> Draco bytes: the points (one per vertex, and one per seam, SplitAtSeams), their
// positions and attributes, the faces over them, and Draco's encoder.
#include <algorithm>
#include <new>
#include <tuple>

#include "absl/container/flat_hash_map.h"
#include "absl/strings/str_cat.h"
#include "core/attributes.h"
#include "core/io/draco_checks.h"
#include "core/io/draco_codec.h"
#include "core/io/draco_convert.h"
#include "draco/compression/encode.h"

namespace meshsmooth {
namespace {

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

// The float32 positions of the points and the faces that have every index in range (the
// validation report counts the others). `points` empty: point i is vertex i.
void AddPositionsAndFaces(const Mesh& mesh, const DracoPoints* points, draco::Mesh& dm) {
  const uint32_t num_points = dm.num_points();
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
  draco::PointAttribute* positions = dm.attribute(dm.AddAttribute(ga, /*identity_mapping=*/true, num_points));
  for (uint32_t i = 0; i < num_points; ++i) {
    const Vec3& p = mesh.positions[points != nullptr ? points->vertex[i] : static_cast<int32_t>(i)];
    const float v[3] = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
    positions->SetAttributeValue(draco::AttributeValueIndex(i), v);
  }
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    const Triangle& t = mesh.triangles[f];
    if (IndexOutOfRange(t, mesh.num_vertices())) continue;
    if (points != nullptr) {
      dm.AddFace({draco::PointIndex(points->corners[3 * f]), draco::PointIndex(points->corners[3 * f + 1]),
                  draco::PointIndex(points->corners[3 * f + 2])});
    } else {
      dm.AddFace({draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
    }
  }
}

// The attributes of `points`: TEX_COORD, NORMAL, COLOR and a named GENERIC attribute per vertex
// property (draco_codec.h, EncodeDraco).
void AddAttributes(const Mesh& mesh, const DracoPoints& points, draco::Mesh& dm) {
  auto entry = [](const CornerAttribute& a, int32_t e, int components, double* v) {
    for (int c = 0; c < components; ++c) {
      v[c] = e >= 0 && e < a.entries() ? a.values[static_cast<size_t>(components) * e + c] : 0.0;
    }
  };
  if (!points.uv.empty()) {
    AddFloatAttribute(dm, draco::GeometryAttribute::TEX_COORD, 2, AllFloat32(mesh.uvs.values),
                      [&](uint32_t p, double* v) { entry(mesh.uvs, points.uv[p], 2, v); });
  }
  if (!points.normal.empty()) {
    // Normals are recomputed from the smoothed positions: float32 is enough.
    AddFloatAttribute(dm, draco::GeometryAttribute::NORMAL, 3, true,
                      [&](uint32_t p, double* v) { entry(mesh.normals, points.normal[p], 3, v); });
  }
  const size_t n = mesh.positions.size();
  if (mesh.colors.size() == n) {
    draco::GeometryAttribute cg;
    cg.Init(draco::GeometryAttribute::COLOR, nullptr, 3, draco::DT_UINT8, true, 3, 0);
    draco::PointAttribute* a = dm.attribute(dm.AddAttribute(cg, /*identity_mapping=*/true, dm.num_points()));
    for (uint32_t p = 0; p < dm.num_points(); ++p) {
      const Rgb& c = mesh.colors[points.vertex[p]];
      const uint8_t rgb[3] = {c.r, c.g, c.b};
      a->SetAttributeValue(draco::AttributeValueIndex(p), rgb);
    }
  }
  for (const VertexProperty& prop : mesh.properties) {
    if (prop.values.size() != n) continue;
    const int id = AddFloatAttribute(dm, draco::GeometryAttribute::GENERIC, 1, AllFloat32(prop.values),
                                     [&](uint32_t p, double* v) { v[0] = prop.values[points.vertex[p]]; });
    NameAttribute(dm, id, prop.name);
  }
}

// EncodeDraco's first checks: a mesh with vertices and faces, options in range, coordinates
// finite and within kMaxCoordinate.
absl::Status CheckMeshAndOptions(const Mesh& mesh, const DracoOptions& options) {
  const int32_t n = mesh.num_vertices();
  if (n == 0 || mesh.triangles.empty()) {
    return absl::InvalidArgumentError("cannot encode an empty mesh (no vertices or no faces)");
  }
  if (absl::Status s = CheckDracoOptions(options); !s.ok()) return s;
  for (int32_t i = 0; i < n; ++i) {
    if (absl::Status s = CheckCoordinates(mesh.positions[i], "vertex", i); !s.ok()) return s;
  }
  return absl::OkStatus();
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

absl::Status CheckPositionsEncodable(const Mesh& mesh, const DracoOptions& options) {
  if (absl::Status s = CheckMeshAndOptions(mesh, options); !s.ok()) return s;
  const int32_t n = mesh.num_vertices();
  if (options.method != DracoMethod::kSequential) return absl::OkStatus();
  const auto faces = std::count_if(mesh.triangles.begin(), mesh.triangles.end(),
                                   [n](const Triangle& t) { return !IndexOutOfRange(t, n); });
  return CheckSequentialPoints(n, faces);
}

absl::StatusOr<std::string> EncodeDraco(const Mesh& mesh, const DracoOptions& options) {
  if (absl::Status s = CheckMeshAndOptions(mesh, options); !s.ok()) return s;
  const int32_t n = mesh.num_vertices();
  const bool attributes = mesh.has_attributes() || !mesh.colors.empty();
  const DracoPoints points = attributes ? SplitAtSeams(mesh) : DracoPoints{};
  draco::Mesh dm;
  dm.set_num_points(attributes ? static_cast<uint32_t>(points.vertex.size()) : static_cast<uint32_t>(n));
  AddPositionsAndFaces(mesh, attributes ? &points : nullptr, dm);
  if (attributes) AddAttributes(mesh, points, dm);
  if (options.method == DracoMethod::kEdgebreaker) {
    const std::vector<uint8_t> used = PointsEdgebreakerKeeps(dm);
    const int64_t dropped = std::count(used.begin(), used.end(), 0);
    if (dropped > 0) return EdgebreakerDropsError(dropped);
  }
  return EncodeWithOptions(dm, options);
}

namespace {

// Draco's encoder on `dm` into `out` (EncodeWithOptions' checks and errors).
absl::Status EncodeToBuffer(const draco::Mesh& dm, const DracoOptions& options, draco::EncoderBuffer& out) {
  if (absl::Status s = CheckDracoOptions(options); !s.ok()) return s;
  // Draco's sequential decoder takes more than three points per face for corrupt data and
  // refuses the bytes: write none rather than a file that nothing can read.
  if (options.method == DracoMethod::kSequential) {
    if (absl::Status s = CheckSequentialPoints(dm.num_points(), dm.num_faces()); !s.ok()) return s;
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
  draco::Status status;
  try {
    status = encoder.EncodeMeshToBuffer(dm, &out);
  } catch (const std::bad_alloc&) {
    return absl::ResourceExhaustedError("out of memory in Draco's encoder");
  }
  if (!status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("Draco encoding failed: ", status.error_msg_string()));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::string> EncodeWithOptions(const draco::Mesh& dm, const DracoOptions& options) {
  draco::EncoderBuffer out;
  if (absl::Status s = EncodeToBuffer(dm, options, out); !s.ok()) return s;
  return std::string(out.data(), out.size());
}

absl::StatusOr<std::string> EncodeReleasing(std::unique_ptr<draco::Mesh> dm, const DracoOptions& options) {
  draco::EncoderBuffer out;
  const absl::Status s = EncodeToBuffer(*dm, options, out);
  dm.reset();
  if (!s.ok()) return s;
  return std::string(out.data(), out.size());
}

std::unique_ptr<draco::Mesh> PositionsAndFacesMesh(const Mesh& mesh) {
  auto dm = std::make_unique<draco::Mesh>();
  dm->set_num_points(static_cast<uint32_t>(mesh.num_vertices()));
  AddPositionsAndFaces(mesh, nullptr, *dm);
  return dm;
}

}  // namespace meshsmooth
