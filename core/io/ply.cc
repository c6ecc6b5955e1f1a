#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <vector>

#include "absl/strings/str_cat.h"
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

  bool Read(PlyType t, double& out) {
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
  for (const Element& e : elements) {
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    int ix = -1, iy = -1, iz = -1, iface = -1;
    int ired = -1, igreen = -1, iblue = -1;
    if (is_vertex) {
      ix = FindProperty(e, "x");
      iy = FindProperty(e, "y");
      iz = FindProperty(e, "z");
      if (ix < 0 || iy < 0 || iz < 0) return error("the vertex element has no x, y, z");
      for (int i : {ix, iy, iz}) {
        if (e.props[i].is_list) return error("x, y, z must be scalar properties");
        info.double_positions |= e.props[i].type == PlyType::kF64;
      }
      // A count that the remaining bytes cannot hold is a corrupt header, not a reason to
      // allocate gigabytes.
      if (static_cast<size_t>(e.count) > reader.remaining()) return error("vertex count exceeds the file size");
      mesh.positions.resize(e.count);
      ired = FindProperty(e, "red");
      igreen = FindProperty(e, "green");
      iblue = FindProperty(e, "blue");
      if (ired >= 0 && igreen >= 0 && iblue >= 0) {
        for (int i : {ired, igreen, iblue}) {
          if (e.props[i].is_list) return error("red, green, blue must be scalar properties");
        }
        mesh.colors.resize(e.count);
      } else {
        ired = igreen = iblue = -1;  // a partial colour is no colour
      }
      have_vertices = true;
    } else if (is_face) {
      iface = FindProperty(e, "vertex_indices");
      if (iface < 0) iface = FindProperty(e, "vertex_index");
      if (iface < 0 || !e.props[iface].is_list) return error("the face element has no vertex_indices list");
      if (static_cast<size_t>(e.count) > reader.remaining()) return error("face count exceeds the file size");
      mesh.triangles.reserve(e.count);
    }
    for (int64_t r = 0; r < e.count; ++r) {
      for (size_t pi = 0; pi < e.props.size(); ++pi) {
        const Property& p = e.props[pi];
        double value = 0.0;
        if (!p.is_list) {
          if (!reader.Read(p.type, value)) {
            return error(absl::StrCat("data ends inside element '", Sv(e.name), "' ", r));
          }
          if (is_vertex) {
            Vec3& pos = mesh.positions[r];
            const int i = static_cast<int>(pi);
            if (i == ix)
              pos.x = value;
            else if (i == iy)
              pos.y = value;
            else if (i == iz)
              pos.z = value;
            else if (i == ired)
              mesh.colors[r].r = ColorChannel(p.type, value);
            else if (i == igreen)
              mesh.colors[r].g = ColorChannel(p.type, value);
            else if (i == iblue)
              mesh.colors[r].b = ColorChannel(p.type, value);
          }
          continue;
        }
        double count_value = 0.0;
        if (!reader.Read(p.count_type, count_value) || !(count_value >= 0.0) || count_value > 1e6) {
          return error(absl::StrCat("bad list length in element '", Sv(e.name), "' ", r));
        }
        const int64_t count = static_cast<int64_t>(count_value);
        const bool is_corners = is_face && static_cast<int>(pi) == iface;
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
          }
        }
        if (is_corners) {
          if (count > 3) ++info.polygons_fanned;
          for (size_t k = 1; k + 1 < corners.size(); ++k) {
            mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
          }
        }
      }
    }
  }
  if (!have_vertices) return error("no vertex element");
  return mesh;
}

absl::StatusOr<std::string> WritePly(const Mesh& mesh, bool binary, bool double_positions) {
  const bool with_colors = !mesh.colors.empty();
  if (with_colors && mesh.colors.size() != mesh.positions.size()) {
    return absl::InvalidArgumentError(absl::StrCat("PLY: the mesh has ", mesh.colors.size(), " colours for ",
                                                   mesh.positions.size(), " vertices (want one per vertex or none)"));
  }
  std::string out =
      absl::StrCat("ply\nformat ", binary ? "binary_little_endian" : "ascii",
                   " 1.0\ncomment written by meshsmooth\nelement vertex ", mesh.positions.size(), "\n",
                   double_positions ? "property double x\nproperty double y\nproperty double z\n"
                                    : "property float x\nproperty float y\nproperty float z\n",
                   with_colors ? "property uchar red\nproperty uchar green\nproperty uchar blue\n" : "",
                   "element face ", mesh.triangles.size(), "\nproperty list uchar int vertex_indices\nend_header\n");
  if (binary) {
    static_assert(std::endian::native == std::endian::little, "binary PLY writer assumes little endian");
    out.reserve(out.size() + mesh.positions.size() * ((double_positions ? 24 : 12) + (with_colors ? 3 : 0)) +
                mesh.triangles.size() * 13);
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      const Vec3& p = mesh.positions[i];
      if (double_positions) {
        const double xyz[3] = {p.x, p.y, p.z};
        out.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
      } else {
        const float xyz[3] = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
        out.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
      }
      if (with_colors) {
        const Rgb& c = mesh.colors[i];
        const char rgb[3] = {static_cast<char>(c.r), static_cast<char>(c.g), static_cast<char>(c.b)};
        out.append(rgb, 3);
      }
    }
    for (const Triangle& t : mesh.triangles) {
      out += static_cast<char>(3);
      out.append(reinterpret_cast<const char*>(t.data()), 3 * sizeof(int32_t));
    }
    return out;
  }
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Vec3& p = mesh.positions[i];
    // Declared float: print the float's own shortest form so it reads back bit-exactly.
    for (double c : {p.x, p.y, p.z}) {
      if (double_positions) {
        AppendDouble(out, c);
      } else {
        char buf[32];
        auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, static_cast<float>(c));
        out.append(buf, ec == std::errc() ? ptr : buf);
      }
      out += ' ';
    }
    if (with_colors) {
      const Rgb& c = mesh.colors[i];
      absl::StrAppend(&out, int{c.r}, " ", int{c.g}, " ", int{c.b}, " ");
    }
    out.back() = '\n';
  }
  for (const Triangle& t : mesh.triangles) absl::StrAppend(&out, "3 ", t[0], " ", t[1], " ", t[2], "\n");
  return out;
}

}  // namespace meshsmooth::io
