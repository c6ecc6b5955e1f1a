#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <optional>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/attributes.h"
#include "core/io/formats.h"

namespace meshsmooth::io {
namespace {

enum class PlyType { kI8, kU8, kI16, kU16, kI32, kU32, kF32, kF64 };

bool TypeFromName(std::string_view name, PlyType& t) {
  static constexpr std::pair<std::string_view, PlyType> kNames[] = {
      {"char", PlyType::kI8},   {"int8", PlyType::kI8},     {"uchar", PlyType::kU8},   {"uint8", PlyType::kU8},
      {"short", PlyType::kI16}, {"int16", PlyType::kI16},   {"ushort", PlyType::kU16}, {"uint16", PlyType::kU16},
      {"int", PlyType::kI32},   {"int32", PlyType::kI32},   {"uint", PlyType::kU32},   {"uint32", PlyType::kU32},
      {"float", PlyType::kF32}, {"float32", PlyType::kF32}, {"double", PlyType::kF64}, {"float64", PlyType::kF64}};
  for (const auto& [n, type] : kNames) {
    if (n == name) {
      t = type;
      return true;
    }
  }
  return false;
}

std::string_view TypeName(PlyType t) {
  static constexpr std::string_view kNames[] = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double"};
  return kNames[static_cast<int>(t)];
}

size_t TypeSize(PlyType t) {
  switch (t) {
    case PlyType::kI8:
    case PlyType::kU8:
      return 1;
    case PlyType::kI16:
    case PlyType::kU16:
      return 2;
    case PlyType::kI32:
    case PlyType::kU32:
    case PlyType::kF32:
      return 4;
    case PlyType::kF64:
      return 8;
  }
  return 1;
}

struct Property {
  std::string_view name;
  PlyType type = PlyType::kF32;
  bool is_list = false;
  PlyType count_type = PlyType::kU8;
};

struct Element {
  std::string_view name;
  int64_t count = 0;
  std::vector<Property> props;
};

enum class Encoding { kAscii, kLittle, kBig };

// Reads scalar values from the body in either encoding; false when the data runs out or a
// token is not a number.
class ValueReader {
 public:
  ValueReader(std::string_view body, Encoding enc) : body_(body), enc_(enc) {}

  [[gnu::always_inline]] bool Read(PlyType t, double& out) {
    if (enc_ == Encoding::kAscii) {
      if (t != PlyType::kF32) return ParseDouble(NextToken(body_), out);
      // A declared float is rounded from the text to float, as a binary file would hold it.
      std::string_view tok = NextToken(body_);
      if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
      float f = 0.0f;
      auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), f);
      out = f;
      return ec == std::errc() && ptr == tok.data() + tok.size();
    }
    const size_t n = TypeSize(t);
    if (pos_ + n > body_.size()) return false;
    unsigned char b[8];
    std::memcpy(b, body_.data() + pos_, n);
    pos_ += n;
    if ((enc_ == Encoding::kBig) == (std::endian::native == std::endian::little)) {
      for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    }
    switch (t) {
      case PlyType::kI8:
        out = static_cast<int8_t>(b[0]);
        break;
      case PlyType::kU8:
        out = b[0];
        break;
      case PlyType::kI16:
        out = Load<int16_t>(b);
        break;
      case PlyType::kU16:
        out = Load<uint16_t>(b);
        break;
      case PlyType::kI32:
        out = Load<int32_t>(b);
        break;
      case PlyType::kU32:
        out = Load<uint32_t>(b);
        break;
      case PlyType::kF32:
        out = Load<float>(b);
        break;
      case PlyType::kF64:
        out = Load<double>(b);
        break;
    }
    return true;
  }
  size_t remaining() const { return enc_ == Encoding::kAscii ? body_.size() : body_.size() - pos_; }

 private:
  template <typename T>
  static T Load(const unsigned char* b) {
    T v;
    std::memcpy(&v, b, sizeof v);
    return v;
  }
  std::string_view body_;
  Encoding enc_;
  size_t pos_ = 0;
};

int FindProperty(const Element& e, std::string_view name) {
  for (size_t i = 0; i < e.props.size(); ++i) {
    if (e.props[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

// One colour channel as 0..255: integer types are taken as 0..255 (clamped), float types as
// 0..1 (the two conventions found in PLY files in the wild).
uint8_t ColorChannel(PlyType t, double value) {
  if (t == PlyType::kF32 || t == PlyType::kF64) value *= 255.0;
  if (!(value > 0.0)) return 0;  // also NaN
  return value >= 255.0 ? 255 : static_cast<uint8_t>(std::lround(value));
}

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
    ValueReader(bytes, Encoding::kLittle).Read(t, v);
    absl::StrAppend(&out, static_cast<int64_t>(v));
  }
  out += ' ';
}

// True when every value is a float32 exactly.
bool AllFloat(const std::vector<double>& values) {
  return std::all_of(values.begin(), values.end(),
                     [](double v) { return !std::isfinite(v) || static_cast<double>(static_cast<float>(v)) == v; });
}

}  // namespace

absl::StatusOr<Mesh> ParsePly(std::string_view data, ReadInfo& info) {
  LineReader lines(data);
  std::string_view line;
  auto error = [](std::string_view what) { return absl::InvalidArgumentError(absl::StrCat("PLY: ", Sv(what))); };
  if (!lines.Next(line) || line != "ply") return error("missing the 'ply' magic line");
  Encoding enc = Encoding::kAscii;
  bool have_format = false, have_end = false;
  std::vector<Element> elements;
  while (lines.Next(line)) {
    std::string_view rest = line;
    const std::string_view key = NextToken(rest);
    if (key == "format") {
      const std::string_view f = NextToken(rest);
      if (f == "ascii")
        enc = Encoding::kAscii;
      else if (f == "binary_little_endian")
        enc = Encoding::kLittle;
      else if (f == "binary_big_endian")
        enc = Encoding::kBig;
      else
        return error(absl::StrCat("unknown format '", Sv(f), "'"));
      have_format = true;
    } else if (key == "element") {
      Element e;
      e.name = NextToken(rest);
      if (!ParseInt(NextToken(rest), e.count) || e.count < 0 || e.count > INT32_MAX) {
        return error(absl::StrCat("bad count for element '", Sv(e.name), "'"));
      }
      // A second one would replace the positions and leave the first one's colours behind.
      if (e.name == "vertex" &&
          std::any_of(elements.begin(), elements.end(), [](const Element& other) { return other.name == "vertex"; })) {
        return error("more than one vertex element");
      }
      elements.push_back(e);
    } else if (key == "property") {
      if (elements.empty()) return error("a property before any element");
      Property p;
      std::string_view type = NextToken(rest);
      if (type == "list") {
        p.is_list = true;
        if (!TypeFromName(NextToken(rest), p.count_type)) return error("bad list count type");
        type = NextToken(rest);
      }
      if (!TypeFromName(type, p.type)) return error(absl::StrCat("unknown property type '", Sv(type), "'"));
      p.name = NextToken(rest);
      // A nameless property could not be written back, nor named in a Draco file's metadata,
      // whose entries cannot be empty.
      if (p.name.empty()) return error(absl::StrCat("a ", Sv(type), " property without a name"));
      elements.back().props.push_back(p);
    } else if (key == "end_header") {
      have_end = true;
      break;
    } else if (key != "comment" && key != "obj_info" && !key.empty()) {
      return error(absl::StrCat("unexpected header line '", Sv(line), "'"));
    }
  }
  if (!have_format || !have_end) return error("incomplete header (no format or no end_header)");

  Mesh mesh;
  ValueReader reader(data.substr(lines.position() > data.size() ? data.size() : lines.position()), enc);
  bool have_vertices = false;
  std::vector<int32_t> corners;
  std::vector<double> corner_uvs;  // a face's `texcoord` list
  // Per-vertex texture coordinates and normals, turned into corner attributes once the faces
  // are known.
  std::vector<double> vertex_uvs, vertex_normals;
  for (const Element& e : elements) {
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    // What each property of the element goes to.
    enum class Role { kSkip, kX, kY, kZ, kRed, kGreen, kBlue, kNx, kNy, kNz, kU, kV, kProperty, kCorners, kTexcoord };
    std::vector<Role> roles(e.props.size(), Role::kSkip);
    std::vector<int> property_slot(e.props.size(), -1);
    auto role_of = [&e](std::string_view name) {
      const int i = FindProperty(e, name);
      return i >= 0 && !e.props[i].is_list ? i : -1;
    };
    if (is_vertex) {
      const int ix = FindProperty(e, "x"), iy = FindProperty(e, "y"), iz = FindProperty(e, "z");
      if (ix < 0 || iy < 0 || iz < 0) return error("the vertex element has no x, y, z");
      for (int i : {ix, iy, iz}) {
        if (e.props[i].is_list) return error("x, y, z must be scalar properties");
        info.double_positions |= e.props[i].type == PlyType::kF64;
      }
      // A count that the remaining bytes cannot hold is a corrupt header, not a reason to
      // allocate gigabytes.
      // Every property of every row takes at least one byte.
      if (static_cast<uint64_t>(e.count) * e.props.size() > reader.remaining()) {
        return error("vertex count exceeds the file size");
      }
      mesh.positions.resize(e.count);
      roles[ix] = Role::kX;
      roles[iy] = Role::kY;
      roles[iz] = Role::kZ;
      const int ired = FindProperty(e, "red"), igreen = FindProperty(e, "green"), iblue = FindProperty(e, "blue");
      if (ired >= 0 && igreen >= 0 && iblue >= 0) {
        for (int i : {ired, igreen, iblue}) {
          if (e.props[i].is_list) return error("red, green, blue must be scalar properties");
        }
        mesh.colors.resize(e.count);
        roles[ired] = Role::kRed;
        roles[igreen] = Role::kGreen;
        roles[iblue] = Role::kBlue;
      }
      const int inx = role_of("nx"), iny = role_of("ny"), inz = role_of("nz");
      if (inx >= 0 && iny >= 0 && inz >= 0) {
        vertex_normals.resize(3 * static_cast<size_t>(e.count));
        roles[inx] = Role::kNx;
        roles[iny] = Role::kNy;
        roles[inz] = Role::kNz;
      }
      // The texture coordinate names found in the wild, in order of preference.
      for (const auto& [u, v] : {std::pair<std::string_view, std::string_view>{"s", "t"},
                                 {"texture_u", "texture_v"},
                                 {"texture_s", "texture_t"},
                                 {"u", "v"}}) {
        const int iu = role_of(u), iv = role_of(v);
        if (iu >= 0 && iv >= 0 && roles[iu] == Role::kSkip && roles[iv] == Role::kSkip) {
          vertex_uvs.resize(2 * static_cast<size_t>(e.count));
          roles[iu] = Role::kU;
          roles[iv] = Role::kV;
          break;
        }
      }
      for (size_t i = 0; i < e.props.size(); ++i) {
        if (roles[i] != Role::kSkip) continue;
        if (e.props[i].is_list) {
          info.dropped.push_back(absl::StrCat("PLY vertex list property '", Sv(e.props[i].name), "'"));
          continue;
        }
        roles[i] = Role::kProperty;
        property_slot[i] = static_cast<int>(mesh.properties.size());
        mesh.properties.push_back(
            {std::string(e.props[i].name), std::string(TypeName(e.props[i].type)), std::vector<double>(e.count)});
      }
      have_vertices = true;
    } else if (is_face) {
      int iface = FindProperty(e, "vertex_indices");
      if (iface < 0) iface = FindProperty(e, "vertex_index");
      if (iface < 0 || !e.props[iface].is_list) return error("the face element has no vertex_indices list");
      if (static_cast<size_t>(e.count) > reader.remaining()) return error("face count exceeds the file size");
      mesh.triangles.reserve(e.count);
      roles[iface] = Role::kCorners;
      const int itex = FindProperty(e, "texcoord");
      if (itex >= 0 && e.props[itex].is_list) {
        roles[itex] = Role::kTexcoord;
        mesh.uvs.components = 2;
      }
      for (size_t i = 0; i < e.props.size(); ++i) {
        if (roles[i] == Role::kSkip) {
          info.dropped.push_back(absl::StrCat("PLY face property '", Sv(e.props[i].name), "'"));
        }
      }
    } else if (e.count > 0) {
      info.dropped.push_back(absl::StrCat(e.count, " PLY '", Sv(e.name), "' elements"));
    }
    for (int64_t r = 0; r < e.count; ++r) {
      corner_uvs.clear();
      bool have_texcoord = false;
      for (size_t pi = 0; pi < e.props.size(); ++pi) {
        const Property& p = e.props[pi];
        double value = 0.0;
        if (!p.is_list) {
          if (!reader.Read(p.type, value)) {
            return error(absl::StrCat("data ends inside element '", Sv(e.name), "' ", r));
          }
          switch (roles[pi]) {
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
              mesh.colors[r].r = ColorChannel(p.type, value);
              break;
            case Role::kGreen:
              mesh.colors[r].g = ColorChannel(p.type, value);
              break;
            case Role::kBlue:
              mesh.colors[r].b = ColorChannel(p.type, value);
              break;
            case Role::kNx:
            case Role::kNy:
            case Role::kNz:
              vertex_normals[3 * r + static_cast<int>(roles[pi]) - static_cast<int>(Role::kNx)] = value;
              break;
            case Role::kU:
            case Role::kV:
              vertex_uvs[2 * r + static_cast<int>(roles[pi]) - static_cast<int>(Role::kU)] = value;
              break;
            case Role::kProperty:
              mesh.properties[property_slot[pi]].values[r] = value;
              break;
            default:
              break;
          }
          continue;
        }
        double count_value = 0.0;
        if (!reader.Read(p.count_type, count_value) || !(count_value >= 0.0) || count_value > 1e6) {
          return error(absl::StrCat("bad list length in element '", Sv(e.name), "' ", r));
        }
        const int64_t count = static_cast<int64_t>(count_value);
        const bool is_corners = roles[pi] == Role::kCorners;
        const bool is_texcoord = roles[pi] == Role::kTexcoord;
        if (is_corners) {
          if (count < 3) return error(absl::StrCat("face ", r, " has fewer than 3 vertices"));
          corners.clear();
        }
        for (int64_t k = 0; k < count; ++k) {
          if (!reader.Read(p.type, value))
            return error(absl::StrCat("data ends inside element '", Sv(e.name), "' ", r));
          if (is_corners) {
            corners.push_back(std::isfinite(value) && value == std::floor(value)
                                  ? ClampIndex(static_cast<int64_t>(std::fmax(-1.0, std::fmin(value, 4e9))))
                                  : -1);
          } else if (is_texcoord) {
            corner_uvs.push_back(value);
          }
        }
        have_texcoord |= is_texcoord;
      }
      if (!is_face) continue;
      if (corners.size() > 3) ++info.polygons_fanned;
      // MeshLab's per-wedge texture coordinates: u v for each corner of the face.
      const bool uv_ok = have_texcoord && corner_uvs.size() == 2 * corners.size();
      auto corner_uv = [&](size_t k) {
        if (!uv_ok) {
          mesh.uvs.corners.push_back(-1);
          return;
        }
        mesh.uvs.corners.push_back(static_cast<int32_t>(mesh.uvs.values.size() / 2));
        mesh.uvs.values.push_back(corner_uvs[2 * k]);
        mesh.uvs.values.push_back(corner_uvs[2 * k + 1]);
      };
      for (size_t k = 1; k + 1 < corners.size(); ++k) {
        mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
        if (mesh.uvs.components == 2) {
          for (size_t c : {size_t{0}, k, k + 1}) corner_uv(c);
        }
      }
    }
  }
  if (!have_vertices) return error("no vertex element");
  // Per-vertex values as corner attributes: each corner names its vertex's entry.
  auto per_vertex = [&mesh](CornerAttribute& a, int components, std::vector<double> values) {
    a.components = components;
    a.values = std::move(values);
    a.corners.resize(3 * mesh.triangles.size());
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const int32_t v = mesh.triangles[t][k];
        a.corners[3 * t + k] = v >= 0 && v < mesh.num_vertices() ? v : -1;
      }
    }
  };
  if (!vertex_uvs.empty()) {
    if (mesh.uvs.empty()) {
      per_vertex(mesh.uvs, 2, std::move(vertex_uvs));
    } else {
      info.dropped.push_back("PLY per-vertex texture coordinates (the faces' texcoord lists are kept)");
    }
  }
  if (!vertex_normals.empty()) per_vertex(mesh.normals, 3, std::move(vertex_normals));
  return mesh;
}

absl::StatusOr<std::string> WritePly(const Mesh& mesh, bool binary, bool double_positions) {
  const bool with_colors = !mesh.colors.empty();
  if (with_colors && mesh.colors.size() != mesh.positions.size()) {
    return absl::InvalidArgumentError(absl::StrCat("PLY: the mesh has ", mesh.colors.size(), " colours for ",
                                                   mesh.positions.size(), " vertices (want one per vertex or none)"));
  }
  for (const VertexProperty& p : mesh.properties) {
    PlyType t;
    if (p.values.size() != mesh.positions.size() || !TypeFromName(p.type, t)) {
      return absl::InvalidArgumentError(absl::StrCat("PLY: property '", p.name, "' has ", p.values.size(),
                                                     " values of type '", p.type, "' for ", mesh.positions.size(),
                                                     " vertices"));
    }
  }
  // Normals and texture coordinates go per vertex when every corner of a vertex agrees; texture
  // coordinates that differ at a vertex (seams) go per face corner as MeshLab's `texcoord`.
  const std::optional<std::vector<double>> normals = PerVertexValues(mesh, mesh.normals);
  const std::optional<std::vector<double>> vertex_uvs = PerVertexValues(mesh, mesh.uvs);
  const bool corner_uvs =
      !mesh.uvs.empty() && !vertex_uvs.has_value() && mesh.uvs.corners.size() == 3 * mesh.triangles.size();
  const bool uv_double = !mesh.uvs.empty() && !AllFloat(mesh.uvs.values);
  struct Column {
    PlyType type;
    const std::vector<double>* values;
    int stride, offset;
  };
  std::vector<Column> extra;  // vertex properties after x y z, in header order
  std::string header = absl::StrCat("ply\nformat ", binary ? "binary_little_endian" : "ascii",
                                    " 1.0\ncomment written by meshsmooth\nelement vertex ", mesh.positions.size(), "\n",
                                    double_positions ? "property double x\nproperty double y\nproperty double z\n"
                                                     : "property float x\nproperty float y\nproperty float z\n");
  if (normals.has_value()) {
    header += "property float nx\nproperty float ny\nproperty float nz\n";
    for (int k = 0; k < 3; ++k) extra.push_back({PlyType::kF32, &*normals, 3, k});
  }
  if (vertex_uvs.has_value()) {
    absl::StrAppend(&header, "property ", uv_double ? "double" : "float", " s\nproperty ",
                    uv_double ? "double" : "float", " t\n");
    for (int k = 0; k < 2; ++k) extra.push_back({uv_double ? PlyType::kF64 : PlyType::kF32, &*vertex_uvs, 2, k});
  }
  if (with_colors) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const VertexProperty& p : mesh.properties) {
    PlyType t = PlyType::kF32;
    TypeFromName(p.type, t);
    absl::StrAppend(&header, "property ", Sv(TypeName(t)), " ", p.name, "\n");
  }
  absl::StrAppend(
      &header, "element face ", mesh.triangles.size(), "\nproperty list uchar int vertex_indices\n",
      corner_uvs ? (uv_double ? "property list uchar double texcoord\n" : "property list uchar float texcoord\n") : "",
      "end_header\n");
  std::string out = std::move(header);
  const PlyType position_type = double_positions ? PlyType::kF64 : PlyType::kF32;
  if (binary) {
    static_assert(std::endian::native == std::endian::little, "binary PLY writer assumes little endian");
    size_t row = 3 * TypeSize(position_type) + (with_colors ? 3 : 0);
    for (const Column& c : extra) row += TypeSize(c.type);
    for (const VertexProperty& p : mesh.properties) {
      PlyType t = PlyType::kF32;
      TypeFromName(p.type, t);
      row += TypeSize(t);
    }
    out.reserve(out.size() + mesh.positions.size() * row + mesh.triangles.size() * (corner_uvs ? 38 : 13));
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      const Vec3& p = mesh.positions[i];
      for (double c : {p.x, p.y, p.z}) AppendBinary(out, position_type, c);
      for (const Column& c : extra) AppendBinary(out, c.type, (*c.values)[c.stride * i + c.offset]);
      if (with_colors) {
        const Rgb& c = mesh.colors[i];
        const char rgb[3] = {static_cast<char>(c.r), static_cast<char>(c.g), static_cast<char>(c.b)};
        out.append(rgb, 3);
      }
      for (const VertexProperty& vp : mesh.properties) {
        PlyType t = PlyType::kF32;
        TypeFromName(vp.type, t);
        AppendBinary(out, t, vp.values[i]);
      }
    }
    for (size_t f = 0; f < mesh.triangles.size(); ++f) {
      out += static_cast<char>(3);
      out.append(reinterpret_cast<const char*>(mesh.triangles[f].data()), 3 * sizeof(int32_t));
      if (corner_uvs) {
        out += static_cast<char>(6);
        for (int k = 0; k < 3; ++k) {
          const int32_t e = mesh.uvs.corners[3 * f + k];
          for (int j = 0; j < 2; ++j) {
            AppendBinary(out, uv_double ? PlyType::kF64 : PlyType::kF32, e >= 0 ? mesh.uvs.values[2 * e + j] : 0.0);
          }
        }
      }
    }
    return out;
  }
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    for (double c : {p.x, p.y, p.z}) AppendText(out, position_type, c);
    for (const Column& c : extra) AppendText(out, c.type, (*c.values)[c.stride * i + c.offset]);
    if (with_colors) {
      const Rgb& c = mesh.colors[i];
      absl::StrAppend(&out, int{c.r}, " ", int{c.g}, " ", int{c.b}, " ");
    }
    for (const VertexProperty& vp : mesh.properties) {
      PlyType t = PlyType::kF32;
      TypeFromName(vp.type, t);
      AppendText(out, t, vp.values[i]);
    }
    out.back() = '\n';
  }
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    const Triangle& t = mesh.triangles[f];
    absl::StrAppend(&out, "3 ", t[0], " ", t[1], " ", t[2]);
    if (corner_uvs) {
      out += " 6";
      for (int k = 0; k < 3; ++k) {
        const int32_t e = mesh.uvs.corners[3 * f + k];
        for (int j = 0; j < 2; ++j) {
          out += ' ';
          AppendText(out, uv_double ? PlyType::kF64 : PlyType::kF32, e >= 0 ? mesh.uvs.values[2 * e + j] : 0.0);
          out.pop_back();
        }
      }
    }
    out += '\n';
  }
  return out;
}

}  // namespace meshsmooth::io
