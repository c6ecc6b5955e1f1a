#include <cmath>
#include <map>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/io/formats.h"

namespace meshsmooth::io {
namespace {

// Reads `count` numbers after the keyword into `out`; false when one is missing or malformed.
bool ReadNumbers(std::string_view& rest, int count, double* out) {
  for (int i = 0; i < count; ++i) {
    if (!ParseDouble(NextToken(rest), out[i])) return false;
  }
  return true;
}

// An OBJ index (1-based; negative counts back from the last entry read) as a 0-based index,
// -1 for 0 and anything out of range of `count` entries so far.
int32_t ObjIndex(int64_t i, int64_t count) {
  const int64_t index = i > 0 ? i - 1 : (i < 0 ? count + i : -1);
  return index < 0 || index >= count ? -1 : ClampIndex(index);
}

// One colour channel written by `v x y z r g b` (0..1) as 0..255.
uint8_t UnitChannel(double value) {
  value *= 255.0;
  if (!(value > 0.0)) return 0;
  return value >= 255.0 ? 255 : static_cast<uint8_t>(std::lround(value));
}

}  // namespace

// OBJ: "v x y z [w | r g b]", "vt u v [w]", "vn x y z", "f v[/vt[/vn]] ..." (1-based,
// negative = relative) and the lines that say how faces are shown (mtllib, usemtl, g, o, s),
// kept as ObjDirective. Lines (`l`), points (`p`), free-form geometry and unknown keywords
// cannot be held: they are counted in ReadInfo::dropped.
absl::StatusOr<Mesh> ParseObj(std::string_view data, ReadInfo& info) {
  Mesh mesh;
  LineReader lines(data);
  std::string_view line;
  struct Corner {
    int32_t v, t, n;
  };
  std::vector<Corner> corners;
  std::vector<Rgb> colors;
  int64_t colored = 0, uv_entries = 0, normal_entries = 0, bad_attribute_indices = 0;
  bool any_uv_corner = false, any_normal_corner = false;
  std::map<std::string, int64_t> dropped;  // keyword -> lines
  auto error = [&lines](std::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("OBJ line ", lines.line_number(), ": ", Sv(what)));
  };
  while (lines.Next(line)) {
    std::string_view rest = line;
    const std::string_view key = NextToken(rest);
    if (key == "v") {
      double c[3];
      if (!ReadNumbers(rest, 3, c)) return error("a vertex needs three numbers");
      mesh.positions.push_back({c[0], c[1], c[2]});
      // "v x y z r g b": a vertex colour (MeshLab and many scanners); "v x y z w": a weight.
      double rgb[3];
      std::string_view after = rest;
      if (ReadNumbers(after, 3, rgb)) {
        colors.resize(mesh.positions.size());
        colors.back() = {UnitChannel(rgb[0]), UnitChannel(rgb[1]), UnitChannel(rgb[2])};
        ++colored;
      }
    } else if (key == "vt") {
      double uv[2];
      if (!ParseDouble(NextToken(rest), uv[0])) return error("a texture coordinate needs a number");
      std::string_view v = NextToken(rest);
      if (v.empty()) {
        uv[1] = 0.0;  // "vt u": a 1D texture, v defaults to 0
      } else if (!ParseDouble(v, uv[1])) {
        return error("bad texture coordinate");
      }
      mesh.uvs.values.insert(mesh.uvs.values.end(), uv, uv + 2);
      ++uv_entries;
    } else if (key == "vn") {
      double n[3];
      if (!ReadNumbers(rest, 3, n)) return error("a normal needs three numbers");
      mesh.normals.values.insert(mesh.normals.values.end(), n, n + 3);
      ++normal_entries;
    } else if (key == "f") {
      corners.clear();
      for (std::string_view tok = NextToken(rest); !tok.empty(); tok = NextToken(rest)) {
        const size_t s1 = tok.find('/');
        int64_t i = 0;
        if (!ParseInt(tok.substr(0, s1), i)) return error(absl::StrCat("bad face index '", Sv(tok), "'"));
        // The vertex index keeps the old rule: out of range stays out of range (the validation
        // report counts the face), so only 0 maps to -1 here.
        const int64_t index = i > 0 ? i - 1 : (i < 0 ? mesh.num_vertices() + i : -1);
        Corner c{ClampIndex(index), -1, -1};
        if (s1 != std::string_view::npos) {
          std::string_view tail = tok.substr(s1 + 1);
          const size_t s2 = tail.find('/');
          const std::string_view t = tail.substr(0, s2);
          const std::string_view n = s2 == std::string_view::npos ? std::string_view() : tail.substr(s2 + 1);
          int64_t k = 0;
          // A malformed attribute index loses the attribute, not the face.
          if (!t.empty()) {
            c.t = ParseInt(t, k) ? ObjIndex(k, uv_entries) : -1;
            bad_attribute_indices += c.t < 0;
            any_uv_corner |= c.t >= 0;
          }
          if (!n.empty()) {
            c.n = ParseInt(n, k) ? ObjIndex(k, normal_entries) : -1;
            bad_attribute_indices += c.n < 0;
            any_normal_corner |= c.n >= 0;
          }
        }
        corners.push_back(c);
      }
      if (corners.size() < 3) return error("a face needs at least 3 vertices");
      if (corners.size() > 3) ++info.polygons_fanned;
      for (size_t k = 1; k + 1 < corners.size(); ++k) {
        mesh.triangles.push_back({corners[0].v, corners[k].v, corners[k + 1].v});
        for (const Corner* c : {&corners[0], &corners[k], &corners[k + 1]}) {
          mesh.uvs.corners.push_back(c->t);
          mesh.normals.corners.push_back(c->n);
        }
      }
    } else if (key == "mtllib" || key == "usemtl" || key == "g" || key == "o" || key == "s") {
      mesh.obj_directives.push_back({mesh.num_triangles(), std::string(line)});
    } else if (!key.empty() && key.front() != '#') {
      ++dropped[std::string(key)];
    }
  }
  if (any_uv_corner) {
    mesh.uvs.components = 2;
  } else {
    mesh.uvs = {};
    if (uv_entries > 0) info.dropped.push_back(absl::StrCat(uv_entries, " texture coordinates no face uses"));
  }
  if (any_normal_corner) {
    mesh.normals.components = 3;
  } else {
    mesh.normals = {};
    if (normal_entries > 0) info.dropped.push_back(absl::StrCat(normal_entries, " normals no face uses"));
  }
  if (colored == mesh.num_vertices() && colored > 0) {
    mesh.colors = std::move(colors);
  } else if (colored > 0) {
    info.dropped.push_back(absl::StrCat("the colours of ", colored, " of ", mesh.num_vertices(),
                                        " vertices (kept only when every vertex has one)"));
  }
  if (bad_attribute_indices > 0) {
    info.dropped.push_back(absl::StrCat(bad_attribute_indices, " texture or normal indices out of range"));
  }
  static const std::map<std::string, std::string> kNames = {{"l", "line elements (l)"}, {"p", "point elements (p)"}};
  for (const auto& [keyword, count] : dropped) {
    auto it = kNames.find(keyword);
    info.dropped.push_back(it != kNames.end() ? absl::StrCat(count, " OBJ ", it->second)
                                              : absl::StrCat(count, " OBJ '", keyword, "' lines"));
  }
  return mesh;
}

std::string WriteObj(const Mesh& mesh) {
  std::string out = "# written by meshsmooth\n";
  const bool with_colors = mesh.colors.size() == mesh.positions.size() && !mesh.colors.empty();
  const bool with_uvs = mesh.uvs.components == 2 && mesh.uvs.corners.size() == 3 * mesh.triangles.size();
  const bool with_normals = mesh.normals.components == 3 && mesh.normals.corners.size() == 3 * mesh.triangles.size();
  out.reserve(out.size() + mesh.positions.size() * 40 + mesh.triangles.size() * (with_uvs ? 60 : 24));
  size_t directive = 0;
  auto directives_before = [&](int64_t t) {
    for (; directive < mesh.obj_directives.size() && mesh.obj_directives[directive].before_triangle <= t; ++directive) {
      absl::StrAppend(&out, mesh.obj_directives[directive].line, "\n");
    }
  };
  directives_before(0);
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    out += "v ";
    AppendPoint(out, mesh.positions[i]);
    if (with_colors) {
      const Rgb& c = mesh.colors[i];
      for (uint8_t channel : {c.r, c.g, c.b}) {
        out += ' ';
        AppendDouble(out, channel / 255.0);
      }
    }
    out += '\n';
  }
  if (with_uvs) {
    for (size_t i = 0; i + 1 < mesh.uvs.values.size(); i += 2) {
      out += "vt ";
      AppendDouble(out, mesh.uvs.values[i]);
      out += ' ';
      AppendDouble(out, mesh.uvs.values[i + 1]);
      out += '\n';
    }
  }
  if (with_normals) {
    for (size_t i = 0; i + 2 < mesh.normals.values.size(); i += 3) {
      out += "vn ";
      AppendPoint(out, {mesh.normals.values[i], mesh.normals.values[i + 1], mesh.normals.values[i + 2]});
      out += '\n';
    }
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    directives_before(static_cast<int64_t>(t));
    out += 'f';
    for (int k = 0; k < 3; ++k) {
      absl::StrAppend(&out, " ", int64_t{mesh.triangles[t][k]} + 1);
      const int32_t uv = with_uvs ? mesh.uvs.corners[3 * t + k] : -1;
      const int32_t n = with_normals ? mesh.normals.corners[3 * t + k] : -1;
      if (uv >= 0 || n >= 0) out += '/';
      if (uv >= 0) absl::StrAppend(&out, int64_t{uv} + 1);
      if (n >= 0) absl::StrAppend(&out, "/", int64_t{n} + 1);
    }
    out += '\n';
  }
  directives_before(INT64_MAX);
  return out;
}

}  // namespace meshsmooth::io
