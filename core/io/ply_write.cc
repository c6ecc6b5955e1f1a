// The PLY writer: a vertex element of x, y, z (float or double), then the normals and texture
// coordinates that are one per vertex, the colours and the vertex properties; a face element of
// triangles, with MeshLab's per-corner `texcoord` lists when texture coordinates differ at a
// vertex. Binary files are little-endian.
#include <bit>
#include <charconv>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/attributes.h"
#include "core/io/formats.h"
#include "core/io/ply_format.h"

namespace meshsmooth::io {
namespace {

// Appends `value` as a binary little-endian value of type `t` (integers rounded and clamped).
void AppendBinary(std::string& out, PlyType t, double value) {
  auto put = [&out](auto v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); };
  auto integer = [value](double lo, double hi) {
    return std::isfinite(value) ? std::fmin(hi, std::fmax(lo, std::round(value))) : 0.0;
  };
  switch (t) {
    case PlyType::kI8:
      put(static_cast<int8_t>(integer(INT8_MIN, INT8_MAX)));
      break;
    case PlyType::kU8:
      put(static_cast<uint8_t>(integer(0, UINT8_MAX)));
      break;
    case PlyType::kI16:
      put(static_cast<int16_t>(integer(INT16_MIN, INT16_MAX)));
      break;
    case PlyType::kU16:
      put(static_cast<uint16_t>(integer(0, UINT16_MAX)));
      break;
    case PlyType::kI32:
      put(static_cast<int32_t>(integer(INT32_MIN, INT32_MAX)));
      break;
    case PlyType::kU32:
      put(static_cast<uint32_t>(integer(0, UINT32_MAX)));
      break;
    case PlyType::kF32:
      put(static_cast<float>(value));
      break;
    case PlyType::kF64:
      put(value);
      break;
  }
}

// Appends `value` as text of type `t` and a space: floats in their own shortest form, so they
// read back bit for bit.
void AppendText(std::string& out, PlyType t, double value) {
  if (t == PlyType::kF64) {
    AppendDouble(out, value);
  } else if (t == PlyType::kF32) {
    char buf[32];
    auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, static_cast<float>(value));
    out.append(buf, ec == std::errc() ? ptr : buf);
  } else {
    std::string bytes;
    AppendBinary(bytes, t, value);  // the same rounding and clamping as binary
    double v = 0.0;
    PlyValueReader(bytes, PlyEncoding::kLittle).Read(t, v);
    absl::StrAppend(&out, static_cast<int64_t>(v));
  }
  out += ' ';
}

// InvalidArgument unless the colours are one per vertex (or none) and every vertex property has
// one value per vertex and a PLY type.
absl::Status CheckWritable(const Mesh& mesh) {
  if (!mesh.colors.empty() && mesh.colors.size() != mesh.positions.size()) {
    return absl::InvalidArgumentError(absl::StrCat("PLY: the mesh has ", mesh.colors.size(), " colours for ",
                                                   mesh.positions.size(), " vertices (want one per vertex or none)"));
  }
  for (const VertexProperty& p : mesh.properties) {
    PlyType t;
    if (p.values.size() != mesh.positions.size() || !PlyTypeFromName(p.type, t)) {
      return absl::InvalidArgumentError(absl::StrCat("PLY: property '", p.name, "' has ", p.values.size(),
                                                     " values of type '", p.type, "' for ", mesh.positions.size(),
                                                     " vertices"));
    }
  }
  return absl::OkStatus();
}

// What the file of a mesh holds besides x, y, z and the faces' vertex indices. `columns` point
// into `normals` and `vertex_uvs`, so a layout is never copied.
struct PlyLayout {
  // A vertex column after x, y, z: entry `offset` of every `stride` values.
  struct Column {
    std::string_view name;
    PlyType type;
    const std::vector<double>* values;
    int stride, offset;
  };

  PlyLayout(const Mesh& mesh, bool double_positions);
  PlyLayout(const PlyLayout&) = delete;
  PlyLayout& operator=(const PlyLayout&) = delete;

  // Bytes of a binary vertex row.
  size_t VertexBytes() const;

  PlyType position_type;
  // Normals and texture coordinates go per vertex when every corner of a vertex agrees; texture
  // coordinates that differ at a vertex (seams) go per face corner as MeshLab's `texcoord`.
  std::optional<std::vector<double>> normals, vertex_uvs;
  bool corner_uvs;                      // a `texcoord` list on each face
  PlyType uv_type;                      // float, or double when float does not hold every value
  std::vector<Column> columns;          // the per-vertex normals and texture coordinates
  bool with_colors;                     // red, green, blue after the columns
  std::vector<PlyType> property_types;  // of Mesh::properties, which come last
};

PlyLayout::PlyLayout(const Mesh& mesh, bool double_positions)
    : position_type(double_positions ? PlyType::kF64 : PlyType::kF32),
      normals(PerVertexValues(mesh, mesh.normals)),
      vertex_uvs(PerVertexValues(mesh, mesh.uvs)),
      corner_uvs(!mesh.uvs.empty() && !vertex_uvs.has_value() && mesh.uvs.corners.size() == 3 * mesh.triangles.size()),
      uv_type(!mesh.uvs.empty() && !AllFloat32(mesh.uvs.values) ? PlyType::kF64 : PlyType::kF32),
      with_colors(!mesh.colors.empty()) {
  static constexpr std::string_view kNormal[] = {"nx", "ny", "nz"}, kUv[] = {"s", "t"};
  if (normals.has_value()) {
    for (int k = 0; k < 3; ++k) columns.push_back({kNormal[k], PlyType::kF32, &*normals, 3, k});
  }
  if (vertex_uvs.has_value()) {
    for (int k = 0; k < 2; ++k) columns.push_back({kUv[k], uv_type, &*vertex_uvs, 2, k});
  }
  for (const VertexProperty& p : mesh.properties) {
    PlyType t = PlyType::kF32;
    PlyTypeFromName(p.type, t);  // CheckWritable() found every type
    property_types.push_back(t);
  }
}

size_t PlyLayout::VertexBytes() const {
  size_t row = 3 * PlyTypeSize(position_type) + (with_colors ? 3 : 0);
  for (const Column& c : columns) row += PlyTypeSize(c.type);
  for (PlyType t : property_types) row += PlyTypeSize(t);
  return row;
}

std::string Header(const Mesh& mesh, const PlyLayout& l, bool binary) {
  std::string header =
      absl::StrCat("ply\nformat ", binary ? "binary_little_endian" : "ascii",
                   " 1.0\ncomment written by meshsmooth\nelement vertex ", mesh.positions.size(), "\n");
  for (std::string_view xyz : {"x", "y", "z"}) {
    absl::StrAppend(&header, "property ", Sv(PlyTypeName(l.position_type)), " ", Sv(xyz), "\n");
  }
  for (const PlyLayout::Column& c : l.columns) {
    absl::StrAppend(&header, "property ", Sv(PlyTypeName(c.type)), " ", Sv(c.name), "\n");
  }
  if (l.with_colors) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (size_t i = 0; i < mesh.properties.size(); ++i) {
    absl::StrAppend(&header, "property ", Sv(PlyTypeName(l.property_types[i])), " ", mesh.properties[i].name, "\n");
  }
  absl::StrAppend(&header, "element face ", mesh.triangles.size(), "\nproperty list uchar int vertex_indices\n");
  if (l.corner_uvs) absl::StrAppend(&header, "property list uchar ", Sv(PlyTypeName(l.uv_type)), " texcoord\n");
  header += "end_header\n";
  return header;
}

// Component `j` of the texture coordinate of corner `k` of face `f` (0 where it has none).
double CornerUv(const Mesh& mesh, size_t f, int k, int j) {
  const int32_t e = mesh.uvs.corners[3 * f + k];
  return e >= 0 ? mesh.uvs.values[2 * e + j] : 0.0;
}

void AppendBinaryVertices(std::string& out, const Mesh& mesh, const PlyLayout& l) {
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    for (double c : {p.x, p.y, p.z}) AppendBinary(out, l.position_type, c);
    for (const PlyLayout::Column& c : l.columns) AppendBinary(out, c.type, (*c.values)[c.stride * i + c.offset]);
    if (l.with_colors) {
      const Rgb& c = mesh.colors[i];
      const char rgb[3] = {static_cast<char>(c.r), static_cast<char>(c.g), static_cast<char>(c.b)};
      out.append(rgb, 3);
    }
    for (size_t k = 0; k < mesh.properties.size(); ++k)
      AppendBinary(out, l.property_types[k], mesh.properties[k].values[i]);
  }
}

void AppendBinaryFaces(std::string& out, const Mesh& mesh, const PlyLayout& l) {
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    out += static_cast<char>(3);
    out.append(reinterpret_cast<const char*>(mesh.triangles[f].data()), 3 * sizeof(int32_t));
    if (!l.corner_uvs) continue;
    out += static_cast<char>(6);
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < 2; ++j) AppendBinary(out, l.uv_type, CornerUv(mesh, f, k, j));
    }
  }
}

void AppendTextVertices(std::string& out, const Mesh& mesh, const PlyLayout& l) {
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    for (double c : {p.x, p.y, p.z}) AppendText(out, l.position_type, c);
    for (const PlyLayout::Column& c : l.columns) AppendText(out, c.type, (*c.values)[c.stride * i + c.offset]);
    if (l.with_colors) {
      const Rgb& c = mesh.colors[i];
      absl::StrAppend(&out, int{c.r}, " ", int{c.g}, " ", int{c.b}, " ");
    }
    for (size_t k = 0; k < mesh.properties.size(); ++k)
      AppendText(out, l.property_types[k], mesh.properties[k].values[i]);
    out.back() = '\n';
  }
}

void AppendTextFaces(std::string& out, const Mesh& mesh, const PlyLayout& l) {
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    const Triangle& t = mesh.triangles[f];
    absl::StrAppend(&out, "3 ", t[0], " ", t[1], " ", t[2]);
    if (l.corner_uvs) {
      out += " 6";
      for (int k = 0; k < 3; ++k) {
        for (int j = 0; j < 2; ++j) {
          out += ' ';
          AppendText(out, l.uv_type, CornerUv(mesh, f, k, j));
          out.pop_back();
        }
      }
    }
    out += '\n';
  }
}

}  // namespace

absl::StatusOr<std::string> WritePly(const Mesh& mesh, bool binary, bool double_positions) {
  if (absl::Status s = CheckWritable(mesh); !s.ok()) return s;
  const PlyLayout layout(mesh, double_positions);
  std::string out = Header(mesh, layout, binary);
  if (binary) {
    static_assert(std::endian::native == std::endian::little, "binary PLY writer assumes little endian");
    out.reserve(out.size() + mesh.positions.size() * layout.VertexBytes() +
                mesh.triangles.size() * (layout.corner_uvs ? 38 : 13));
    AppendBinaryVertices(out, mesh, layout);
    AppendBinaryFaces(out, mesh, layout);
  } else {
    AppendTextVertices(out, mesh, layout);
    AppendTextFaces(out, mesh, layout);
  }
  return out;
}

}  // namespace meshsmooth::io
