// The PLY reader: the header (ParsePlyHeader), then each element's rows in header order. The
// vertex element's property table says which columns are positions, colours, normals and
// texture coordinates, and every other scalar column becomes a vertex property; the face
// element's lists are fanned into triangles; the rows of any other element are read and
// dropped.
#include <cmath>
#include <initializer_list>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/io/formats.h"
#include "core/io/ply_format.h"

namespace meshsmooth::io {
namespace {

// What a column of an element's rows goes to.
enum class Role { kSkip, kX, kY, kZ, kRed, kGreen, kBlue, kNx, kNy, kNz, kU, kV, kProperty, kCorners, kTexcoord };

// The roles of an element's columns, in the order of its property table.
struct RowPlan {
  explicit RowPlan(const PlyElement& e, bool face = false)
      : roles(e.props.size(), Role::kSkip), property_slot(e.props.size(), -1), is_face(face) {}
  // Gives `columns` the roles from `first` on, in order (x, y, z; red, green, blue; ...).
  void Claim(std::initializer_list<int> columns, Role first) {
    int role = static_cast<int>(first);
    for (int c : columns) roles[c] = static_cast<Role>(role++);
  }

  std::vector<Role> roles;
  std::vector<int> property_slot;  // of a kProperty column: its index in Mesh::properties
  bool is_face = false;
};

// The mesh as the rows fill it.
struct PlyBody {
  Mesh mesh;
  bool have_vertices = false;
  // Per-vertex texture coordinates and normals, turned into corner attributes once the faces
  // are known.
  std::vector<double> vertex_uvs, vertex_normals;
  // The face row being read: its corners and its `texcoord` list.
  std::vector<int32_t> corners;
  std::vector<double> corner_uvs;
};

// One colour channel as 0..255: integer types are taken as 0..255 (clamped), float types as
// 0..1 (the two conventions found in PLY files in the wild).
uint8_t ColorChannel(PlyType t, double value) {
  if (t == PlyType::kF32 || t == PlyType::kF64) value *= 255.0;
  if (!(value > 0.0)) return 0;  // also NaN
  return value >= 255.0 ? 255 : static_cast<uint8_t>(std::lround(value));
}

// A face list's value as a vertex index; -1 (out of range) for one that is not a whole number.
int32_t CornerIndex(double value) {
  return std::isfinite(value) && value == std::floor(value)
             ? ClampIndex(static_cast<int64_t>(std::fmax(-1.0, std::fmin(value, 4e9))))
             : -1;
}

// Red, green and blue, when the table has all three.
absl::Status ClaimColours(const PlyElement& e, RowPlan& plan, PlyBody& body) {
  const int ired = e.Find("red"), igreen = e.Find("green"), iblue = e.Find("blue");
  if (ired < 0 || igreen < 0 || iblue < 0) return absl::OkStatus();
  for (int i : {ired, igreen, iblue}) {
    if (e.props[i].is_list) return PlyError("red, green, blue must be scalar properties");
  }
  body.mesh.colors.resize(e.count);
  plan.Claim({ired, igreen, iblue}, Role::kRed);
  return absl::OkStatus();
}

// Normals and texture coordinates per vertex, when the table has all their components.
void ClaimNormalsAndTexcoords(const PlyElement& e, RowPlan& plan, PlyBody& body) {
  const int inx = e.FindScalar("nx"), iny = e.FindScalar("ny"), inz = e.FindScalar("nz");
  if (inx >= 0 && iny >= 0 && inz >= 0) {
    body.vertex_normals.resize(3 * static_cast<size_t>(e.count));
    plan.Claim({inx, iny, inz}, Role::kNx);
  }
  // The texture coordinate names found in the wild, in order of preference.
  for (const auto& [u, v] : {std::pair<std::string_view, std::string_view>{"s", "t"},
                             {"texture_u", "texture_v"},
                             {"texture_s", "texture_t"},
                             {"u", "v"}}) {
    const int iu = e.FindScalar(u), iv = e.FindScalar(v);
    if (iu >= 0 && iv >= 0 && plan.roles[iu] == Role::kSkip && plan.roles[iv] == Role::kSkip) {
      body.vertex_uvs.resize(2 * static_cast<size_t>(e.count));
      plan.Claim({iu, iv}, Role::kU);
      return;
    }
  }
}

// The vertex element: x, y, z, then what ClaimColours and ClaimNormalsAndTexcoords take; every
// other scalar column is a vertex property of the type it is declared with, and lists are
// dropped.
absl::StatusOr<RowPlan> PlanVertexRows(const PlyElement& e, size_t remaining, PlyBody& body, ReadInfo& info) {
  RowPlan plan(e);
  const int ix = e.Find("x"), iy = e.Find("y"), iz = e.Find("z");
  if (ix < 0 || iy < 0 || iz < 0) return PlyError("the vertex element has no x, y, z");
  for (int i : {ix, iy, iz}) {
    if (e.props[i].is_list) return PlyError("x, y, z must be scalar properties");
    info.double_positions |= e.props[i].type == PlyType::kF64;
  }
  // A count that the remaining bytes cannot hold is a corrupt header, not a reason to
  // allocate gigabytes.
  // Every property of every row takes at least one byte.
  if (static_cast<uint64_t>(e.count) * e.props.size() > remaining)
    return PlyError("vertex count exceeds the file size");
  body.mesh.positions.resize(e.count);
  plan.Claim({ix, iy, iz}, Role::kX);
  if (absl::Status s = ClaimColours(e, plan, body); !s.ok()) return s;
  ClaimNormalsAndTexcoords(e, plan, body);
  for (size_t i = 0; i < e.props.size(); ++i) {
    if (plan.roles[i] != Role::kSkip) continue;
    const PlyProperty& p = e.props[i];
    if (p.is_list) {
      info.dropped.push_back(absl::StrCat("PLY vertex list property '", Sv(p.name), "'"));
      continue;
    }
    plan.roles[i] = Role::kProperty;
    plan.property_slot[i] = static_cast<int>(body.mesh.properties.size());
    body.mesh.properties.push_back(
        {std::string(p.name), std::string(PlyTypeName(p.type)), std::vector<double>(e.count)});
  }
  body.have_vertices = true;
  return plan;
}

// The face element: its vertex_indices (or vertex_index) list and MeshLab's per-corner
// `texcoord` list; any other column is dropped.
absl::StatusOr<RowPlan> PlanFaceRows(const PlyElement& e, size_t remaining, PlyBody& body, ReadInfo& info) {
  RowPlan plan(e, /*face=*/true);
  int iface = e.Find("vertex_indices");
  if (iface < 0) iface = e.Find("vertex_index");
  if (iface < 0 || !e.props[iface].is_list) return PlyError("the face element has no vertex_indices list");
  if (static_cast<size_t>(e.count) > remaining) return PlyError("face count exceeds the file size");
  body.mesh.triangles.reserve(e.count);
  plan.roles[iface] = Role::kCorners;
  const int itex = e.Find("texcoord");
  if (itex >= 0 && e.props[itex].is_list) {
    plan.roles[itex] = Role::kTexcoord;
    body.mesh.uvs.components = 2;
  }
  for (size_t i = 0; i < e.props.size(); ++i) {
    if (plan.roles[i] == Role::kSkip) {
      info.dropped.push_back(absl::StrCat("PLY face property '", Sv(e.props[i].name), "'"));
    }
  }
  return plan;
}

absl::StatusOr<RowPlan> PlanRows(const PlyElement& e, size_t remaining, PlyBody& body, ReadInfo& info) {
  if (e.name == "vertex") return PlanVertexRows(e, remaining, body, info);
  if (e.name == "face") return PlanFaceRows(e, remaining, body, info);
  if (e.count > 0) info.dropped.push_back(absl::StrCat(e.count, " PLY '", Sv(e.name), "' elements"));
  return RowPlan(e);
}

absl::Status DataEndsError(const PlyElement& e, int64_t row) {
  return PlyError(absl::StrCat("data ends inside element '", Sv(e.name), "' ", row));
}

// Stores the scalar `value` of column `column` of row `r` where its role says.
void StoreScalar(const RowPlan& plan, size_t column, PlyType type, double value, int64_t r, PlyBody& body) {
  Mesh& mesh = body.mesh;
  const Role role = plan.roles[column];
  switch (role) {
    case Role::kX:
      mesh.positions[r].x = value;
      break;
    case Role::kY:
      mesh.positions[r].y = value;
      break;
    case Role::kZ:
      mesh.positions[r].z = value;
      break;
    case Role::kRed:
      mesh.colors[r].r = ColorChannel(type, value);
      break;
    case Role::kGreen:
      mesh.colors[r].g = ColorChannel(type, value);
      break;
    case Role::kBlue:
      mesh.colors[r].b = ColorChannel(type, value);
      break;
    case Role::kNx:
    case Role::kNy:
    case Role::kNz:
      body.vertex_normals[3 * r + static_cast<int>(role) - static_cast<int>(Role::kNx)] = value;
      break;
    case Role::kU:
    case Role::kV:
      body.vertex_uvs[2 * r + static_cast<int>(role) - static_cast<int>(Role::kU)] = value;
      break;
    case Role::kProperty:
      mesh.properties[plan.property_slot[column]].values[r] = value;
      break;
    default:
      break;
  }
}

// Reads a list of row `r`: a face's corners or texture coordinates, or a list that is dropped.
absl::Status ReadList(const PlyElement& e, int64_t r, const PlyProperty& p, Role role, PlyValueReader& reader,
                      PlyBody& body) {
  double count_value = 0.0;
  if (!reader.Read(p.count_type, count_value) || !(count_value >= 0.0) || count_value > 1e6) {
    return PlyError(absl::StrCat("bad list length in element '", Sv(e.name), "' ", r));
  }
  const int64_t count = static_cast<int64_t>(count_value);
  if (role == Role::kCorners) {
    if (count < 3) return PlyError(absl::StrCat("face ", r, " has fewer than 3 vertices"));
    body.corners.clear();
  }
  double value = 0.0;
  for (int64_t k = 0; k < count; ++k) {
    if (!reader.Read(p.type, value)) return DataEndsError(e, r);
    if (role == Role::kCorners) {
      body.corners.push_back(CornerIndex(value));
    } else if (role == Role::kTexcoord) {
      body.corner_uvs.push_back(value);
    }
  }
  return absl::OkStatus();
}

// Fans the face just read into triangles, with its texture coordinates when its `texcoord`
// list has a u, v pair for each corner (-1, none, otherwise).
void AddFace(bool have_texcoord, PlyBody& body, ReadInfo& info) {
  Mesh& mesh = body.mesh;
  const std::vector<int32_t>& corners = body.corners;
  if (corners.size() > 3) ++info.polygons_fanned;
  const bool uv_ok = have_texcoord && body.corner_uvs.size() == 2 * corners.size();
  auto corner_uv = [&](size_t k) {
    if (!uv_ok) {
      mesh.uvs.corners.push_back(-1);
      return;
    }
    mesh.uvs.corners.push_back(static_cast<int32_t>(mesh.uvs.values.size() / 2));
    mesh.uvs.values.push_back(body.corner_uvs[2 * k]);
    mesh.uvs.values.push_back(body.corner_uvs[2 * k + 1]);
  };
  for (size_t k = 1; k + 1 < corners.size(); ++k) {
    mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
    if (mesh.uvs.components == 2) {
      for (size_t c : {size_t{0}, k, k + 1}) corner_uv(c);
    }
  }
}

// Reads the element's rows, each value to where its column's role says.
absl::Status ReadRows(const PlyElement& e, const RowPlan& plan, PlyValueReader& reader, PlyBody& body, ReadInfo& info) {
  for (int64_t r = 0; r < e.count; ++r) {
    body.corner_uvs.clear();
    bool have_texcoord = false;
    for (size_t pi = 0; pi < e.props.size(); ++pi) {
      const PlyProperty& p = e.props[pi];
      if (!p.is_list) {
        double value = 0.0;
        if (!reader.Read(p.type, value)) return DataEndsError(e, r);
        StoreScalar(plan, pi, p.type, value, r, body);
        continue;
      }
      if (absl::Status s = ReadList(e, r, p, plan.roles[pi], reader, body); !s.ok()) return s;
      have_texcoord |= plan.roles[pi] == Role::kTexcoord;
    }
    if (plan.is_face) AddFace(have_texcoord, body, info);
  }
  return absl::OkStatus();
}

// Per-vertex values as a corner attribute: each corner names its vertex's entry (-1 for a
// vertex out of range).
void SetPerVertex(const Mesh& mesh, CornerAttribute& a, int components, std::vector<double> values) {
  a.components = components;
  a.values = std::move(values);
  a.corners.resize(3 * mesh.triangles.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int32_t v = mesh.triangles[t][k];
      a.corners[3 * t + k] = v >= 0 && v < mesh.num_vertices() ? v : -1;
    }
  }
}

// The mesh once every row is read: the per-vertex texture coordinates (unless the faces had
// their own) and normals as corner attributes.
absl::StatusOr<Mesh> FinishMesh(PlyBody& body, ReadInfo& info) {
  if (!body.have_vertices) return PlyError("no vertex element");
  Mesh& mesh = body.mesh;
  if (!body.vertex_uvs.empty()) {
    if (mesh.uvs.empty()) {
      SetPerVertex(mesh, mesh.uvs, 2, std::move(body.vertex_uvs));
    } else {
      info.dropped.push_back("PLY per-vertex texture coordinates (the faces' texcoord lists are kept)");
    }
  }
  if (!body.vertex_normals.empty()) SetPerVertex(mesh, mesh.normals, 3, std::move(body.vertex_normals));
  return std::move(mesh);
}

}  // namespace

absl::StatusOr<Mesh> ParsePly(std::string_view data, ReadInfo& info) {
  absl::StatusOr<PlyHeader> header = ParsePlyHeader(data);
  if (!header.ok()) return header.status();
  PlyValueReader reader(data.substr(header->body_offset), header->encoding);
  PlyBody body;
  for (const PlyElement& e : header->elements) {
    absl::StatusOr<RowPlan> plan = PlanRows(e, reader.remaining(), body, info);
    if (!plan.ok()) return plan.status();
    if (absl::Status s = ReadRows(e, *plan, reader, body, info); !s.ok()) return s;
  }
  return FinishMesh(body, info);
}

}  // namespace meshsmooth::io
