#include "absl/strings/str_cat.h"
#include "core/io/formats.h"

namespace meshsmooth::io {
namespace {

// Next line that is neither empty nor a comment, with any trailing '#' comment removed.
bool NextDataLine(LineReader& lines, std::string_view& line) {
  while (lines.Next(line)) {
    line = line.substr(0, line.find('#'));
    std::string_view probe = line;
    if (!NextToken(probe).empty()) return true;
  }
  return false;
}

}  // namespace

// OFF / COFF / NOFF / CNOFF (ASCII): header, "V F E" counts, V vertex lines (extra columns such
// as colours or normals are skipped), F face lines "n i1 ... in [colour]".
absl::StatusOr<Mesh> ParseOff(std::string_view data, ReadInfo& info) {
  LineReader lines(data);
  std::string_view line;
  auto error = [&lines](std::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("OFF line ", lines.line_number(), ": ", Sv(what)));
  };
  if (!NextDataLine(lines, line)) return absl::InvalidArgumentError("OFF: empty file");
  std::string_view rest = line;
  std::string_view magic = NextToken(rest);
  if (magic.size() < 3 || magic.substr(magic.size() - 3) != "OFF") return error("missing the OFF header");
  if (magic.find("ST") != std::string_view::npos || magic.find('4') != std::string_view::npos) {
    return error("only 3-D OFF without texture coordinates is supported");
  }
  std::string_view probe = rest;
  const std::string_view first = NextToken(probe);
  if (first == "BINARY") return error("binary OFF is not supported");
  if (first.empty()) {  // the counts are on the next line
    if (!NextDataLine(lines, line)) return error("missing the vertex and face counts");
    rest = line;
  }
  int64_t nv = 0, nf = 0;
  if (!ParseInt(NextToken(rest), nv) || !ParseInt(NextToken(rest), nf) || nv < 0 || nf < 0 || nv > INT32_MAX ||
      nf > INT32_MAX) {
    return error("bad vertex and face counts");
  }
  Mesh mesh;
  mesh.positions.reserve(std::min<size_t>(nv, data.size() / 6 + 1));
  for (int64_t i = 0; i < nv; ++i) {
    if (!NextDataLine(lines, line)) return error(absl::StrCat("expected ", nv, " vertices, found ", i));
    rest = line;
    Vec3 p;
    if (!ParseDouble(NextToken(rest), p.x) || !ParseDouble(NextToken(rest), p.y) ||
        !ParseDouble(NextToken(rest), p.z)) {
      return error("a vertex needs three numbers");
    }
    mesh.positions.push_back(p);
  }
  mesh.triangles.reserve(std::min<size_t>(nf, data.size() / 8 + 1));
  std::vector<int32_t> corners;
  for (int64_t i = 0; i < nf; ++i) {
    if (!NextDataLine(lines, line)) return error(absl::StrCat("expected ", nf, " faces, found ", i));
    rest = line;
    int64_t count = 0;
    if (!ParseInt(NextToken(rest), count) || count < 3) return error("a face needs at least 3 vertices");
    corners.clear();
    for (int64_t k = 0; k < count; ++k) {
      int64_t index = 0;
      if (!ParseInt(NextToken(rest), index)) return error("bad face index");
      corners.push_back(ClampIndex(index));
    }
    if (count > 3) ++info.polygons_fanned;
    for (size_t k = 1; k + 1 < corners.size(); ++k) {
      mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
    }
  }
  return mesh;
}

std::string WriteOff(const Mesh& mesh) {
  std::string out = absl::StrCat("OFF\n", mesh.positions.size(), " ", mesh.triangles.size(), " 0\n");
  for (const Vec3& p : mesh.positions) {
    AppendPoint(out, p);
    out += '\n';
  }
  for (const Triangle& t : mesh.triangles) absl::StrAppend(&out, "3 ", t[0], " ", t[1], " ", t[2], "\n");
  return out;
}

}  // namespace meshsmooth::io
