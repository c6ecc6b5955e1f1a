#include <cstring>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/io/formats.h"
#include "core/weld.h"

namespace meshsmooth::io {
namespace {

bool LooksBinary(std::string_view data) {
  if (data.size() < 84) return false;
  uint32_t n = 0;
  std::memcpy(&n, data.data() + 80, 4);
  return data.size() == 84 + 50 * static_cast<uint64_t>(n);
}

// OK when `facets` facets have at most kMaxWeldPoints corners, all WeldPoints can number (a
// binary header can declare 2^32 - 1 facets).
absl::Status CheckFacetCount(int64_t facets) {
  if (3 * facets <= kMaxWeldPoints) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("STL: ", facets, " facets have ", 3 * facets,
                                                 " corners; meshsmooth reads at most ", kMaxWeldPoints, " (2^31 - 1)"));
}

// Facets of three consecutive corners, welded.
Mesh FromCorners(const std::vector<Vec3>& corners, ReadInfo& info) {
  Welded w = WeldPoints(corners);
  Mesh mesh;
  mesh.positions = std::move(w.positions);
  mesh.triangles.resize(corners.size() / 3);
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    for (int c = 0; c < 3; ++c) mesh.triangles[f][c] = w.point_to_vertex[3 * f + c];
  }
  info.welded_corners = w.merged;
  return mesh;
}

}  // namespace

absl::StatusOr<Mesh> ParseStl(std::string_view data, ReadInfo& info) {
  // A triangle soup: corners at the same position become one vertex, in order of first
  // appearance (WeldPoints); the corners are read first, three per facet.
  std::vector<Vec3> corners;
  if (LooksBinary(data)) {
    uint32_t n = 0;
    std::memcpy(&n, data.data() + 80, 4);
    if (absl::Status s = CheckFacetCount(n); !s.ok()) return s;
    corners.reserve(3 * static_cast<size_t>(n));
    for (uint32_t f = 0; f < n; ++f) {
      const char* rec = data.data() + 84 + 50 * static_cast<size_t>(f);
      for (int c = 0; c < 3; ++c) {
        float xyz[3];
        std::memcpy(xyz, rec + 12 + 12 * c, sizeof xyz);
        corners.push_back({xyz[0], xyz[1], xyz[2]});
      }
    }
    return FromCorners(corners, info);
  }
  std::string_view rest = data;
  if (NextToken(rest) != "solid") {
    return absl::InvalidArgumentError(
        "STL: neither binary (size does not match the face count) nor ASCII (no 'solid')");
  }
  int corner = 0;
  for (std::string_view tok = NextToken(rest); !tok.empty(); tok = NextToken(rest)) {
    if (tok == "vertex") {
      Vec3 p;
      if (!ParseDouble(NextToken(rest), p.x) || !ParseDouble(NextToken(rest), p.y) ||
          !ParseDouble(NextToken(rest), p.z)) {
        return absl::InvalidArgumentError(absl::StrCat("STL: bad vertex in facet ", (corners.size() - corner) / 3));
      }
      if (corner == 3) {
        return absl::InvalidArgumentError(
            absl::StrCat("STL: facet ", (corners.size() - corner) / 3, " has more than 3 vertices"));
      }
      if (corner == 0) {
        if (absl::Status s = CheckFacetCount(static_cast<int64_t>(corners.size() / 3) + 1); !s.ok()) return s;
      }
      corners.push_back(p);
      ++corner;
    } else if (tok == "endloop") {
      if (corner != 3) {
        return absl::InvalidArgumentError(
            absl::StrCat("STL: facet ", (corners.size() - corner) / 3, " has ", corner, " vertices"));
      }
      corner = 0;
    }
  }
  if (corner != 0) {
    return absl::InvalidArgumentError(absl::StrCat("STL: facet ", (corners.size() - corner) / 3, " has no 'endloop'"));
  }
  return FromCorners(corners, info);
}

std::string WriteStl(const Mesh& mesh) {
  const int32_t n = mesh.num_vertices();
  uint32_t count = 0;
  for (const Triangle& t : mesh.triangles) count += IsUsableTriangle(t, n);
  std::string out(80, '\0');
  const char header[] = "binary STL written by meshsmooth";
  std::memcpy(out.data(), header, sizeof header - 1);
  out.append(reinterpret_cast<const char*>(&count), 4);
  out.reserve(84 + 50 * static_cast<size_t>(count));
  for (const Triangle& t : mesh.triangles) {
    if (!IsUsableTriangle(t, n)) continue;  // STL cannot reference a vertex that is not there
    const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    Vec3 nrm = Cross(b - a, c - a);
    const double len = Norm(nrm);
    if (len > 0.0) nrm *= 1.0 / len;
    float rec[12] = {static_cast<float>(nrm.x), static_cast<float>(nrm.y), static_cast<float>(nrm.z)};
    int k = 3;
    for (const Vec3* p : {&a, &b, &c}) {
      rec[k++] = static_cast<float>(p->x);
      rec[k++] = static_cast<float>(p->y);
      rec[k++] = static_cast<float>(p->z);
    }
    out.append(reinterpret_cast<const char*>(rec), sizeof rec);
    out.append(2, '\0');
  }
  return out;
}

}  // namespace meshsmooth::io
