#include "absl/strings/str_cat.h"
#include "core/io/formats.h"

namespace meshsmooth::io {

// OBJ: "v x y z [w|r g b]" and "f i[/t[/n]] ..." lines (1-based, negative = relative);
// everything else (vt, vn, g, o, usemtl, l, ...) is skipped.
absl::StatusOr<Mesh> ParseObj(std::string_view data, ReadInfo& info) {
  Mesh mesh;
  LineReader lines(data);
  std::string_view line;
  std::vector<int32_t> corners;
  while (lines.Next(line)) {
    std::string_view rest = line;
    const std::string_view key = NextToken(rest);
    if (key == "v") {
      Vec3 p;
      double* c[3] = {&p.x, &p.y, &p.z};
      for (double* x : c) {
        if (!ParseDouble(NextToken(rest), *x)) {
          return absl::InvalidArgumentError(
              absl::StrCat("OBJ line ", lines.line_number(), ": a vertex needs three numbers"));
        }
      }
      mesh.positions.push_back(p);
    } else if (key == "f") {
      corners.clear();
      for (std::string_view tok = NextToken(rest); !tok.empty(); tok = NextToken(rest)) {
        int64_t i = 0;
        if (!ParseInt(tok.substr(0, tok.find('/')), i)) {
          return absl::InvalidArgumentError(
              absl::StrCat("OBJ line ", lines.line_number(), ": bad face index '", Sv(tok), "'"));
        }
        // 1-based; negative counts back from the last vertex read; 0 is invalid.
        const int64_t index = i > 0 ? i - 1 : (i < 0 ? mesh.num_vertices() + i : -1);
        corners.push_back(ClampIndex(index));
      }
      if (corners.size() < 3) {
        return absl::InvalidArgumentError(
            absl::StrCat("OBJ line ", lines.line_number(), ": a face needs at least 3 vertices"));
      }
      if (corners.size() > 3) ++info.polygons_fanned;
      for (size_t k = 1; k + 1 < corners.size(); ++k) {
        mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
      }
    }
  }
  return mesh;
}

std::string WriteObj(const Mesh& mesh) {
  std::string out = "# written by meshsmooth\n";
  out.reserve(out.size() + mesh.positions.size() * 40 + mesh.triangles.size() * 24);
  for (const Vec3& p : mesh.positions) {
    out += "v ";
    AppendPoint(out, p);
    out += '\n';
  }
  for (const Triangle& t : mesh.triangles) {
    absl::StrAppend(&out, "f ", int64_t{t[0]} + 1, " ", int64_t{t[1]} + 1, " ", int64_t{t[2]} + 1, "\n");
  }
  return out;
}

}  // namespace meshsmooth::io
