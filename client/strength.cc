#include "client/strength.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace meshsmooth::client {
namespace {

// Comma-separated finite numbers, exactly `count` of them; none when the text is not that.
std::optional<std::vector<double>> Numbers(absl::string_view text, size_t count) {
  std::vector<double> out;
  for (absl::string_view part : absl::StrSplit(text, ',')) {
    double value = 0.0;
    if (!absl::SimpleAtod(absl::StripAsciiWhitespace(part), &value) || !std::isfinite(value)) return std::nullopt;
    out.push_back(value);
  }
  if (out.size() != count) return std::nullopt;
  return out;
}

double SmoothStep(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

// --weight's values, one a vertex.
absl::StatusOr<std::vector<float>> WeightValues(const Mesh& mesh, const WeightSpec& w, const std::string& flag) {
  const auto it = std::find_if(mesh.properties.begin(), mesh.properties.end(),
                               [&](const VertexProperty& p) { return p.name == w.property; });
  if (it == mesh.properties.end()) {
    std::vector<std::string> names;
    for (const VertexProperty& p : mesh.properties) names.push_back(p.name);
    return absl::InvalidArgumentError(absl::StrCat(flag, ": the input has no vertex property '", w.property, "' (",
                                                   names.empty() ? "it has none; --weight reads a PLY vertex property"
                                                                 : absl::StrCat("it has ", absl::StrJoin(names, ", ")),
                                                   ")"));
  }
  std::vector<float> out(mesh.positions.size(), 1.0f);
  for (size_t v = 0; v < out.size() && v < it->values.size(); ++v) {
    const double x = it->values[v];
    if (!std::isfinite(x)) return absl::InvalidArgumentError(absl::StrCat(flag, ": vertex ", v, " has ", x));
    if (w.map) {
      const auto [lo, hi] = *w.map;
      out[v] = static_cast<float>(std::clamp((x - lo) / (hi - lo), 0.0, 1.0));
    } else if (x < 0.0 || x > 1.0) {
      return absl::InvalidArgumentError(absl::StrCat(flag, ": vertex ", v, " has ", x,
                                                     ", outside [0, 1]; map the property's range onto it: --weight ",
                                                     w.property, ":LO,HI"));
    } else {
      out[v] = static_cast<float>(x);
    }
  }
  return out;
}

// Zeroes `strength` at --fixed's indices.
absl::Status HoldFixed(const std::string& path, std::vector<float>& strength) {
  std::ifstream in(path);
  if (!in) return absl::InvalidArgumentError(absl::StrCat("--fixed ", path, ": cannot read the file"));
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const absl::string_view content = absl::string_view(line).substr(0, line.find('#'));
    for (absl::string_view token : absl::StrSplit(content, absl::ByAnyChar(" \t\r,;"), absl::SkipEmpty())) {
      int64_t index = 0;
      if (!absl::SimpleAtoi(token, &index)) {
        return absl::InvalidArgumentError(
            absl::StrCat("--fixed ", path, ": line ", number, ": '", std::string(token), "' is not a vertex index"));
      }
      if (index < 0 || index >= static_cast<int64_t>(strength.size())) {
        return absl::InvalidArgumentError(absl::StrCat("--fixed ", path, ": line ", number, ": index ", index,
                                                       " is out of range (the mesh has ", strength.size(),
                                                       " vertices, 0 to ", strength.size() - 1, ")"));
      }
      strength[index] = 0.0f;
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<WeightSpec> ParseWeight(const std::string& text) {
  WeightSpec w;
  const size_t colon = text.find(':');
  w.property = text.substr(0, colon);
  if (w.property.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--weight ", text, ": name a vertex property, e.g. --weight quality or --weight quality:0,255"));
  }
  if (colon == std::string::npos) return w;
  const std::optional<std::vector<double>> range = Numbers(absl::string_view(text).substr(colon + 1), 2);
  if (!range || (*range)[0] == (*range)[1]) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--weight ", text, ": after the property give LO,HI, two different finite numbers (LO -> 0, HI -> 1)"));
  }
  w.map = std::array<double, 2>{(*range)[0], (*range)[1]};
  return w;
}

absl::StatusOr<RegionSpec> ParseRegion(const std::string& text) {
  RegionSpec r;
  const size_t colon = text.find(':');
  const std::string kind = text.substr(0, colon);
  const absl::string_view rest = colon == std::string::npos ? "" : absl::string_view(text).substr(colon + 1);
  if (kind == "box") {
    const std::optional<std::vector<double>> c = Numbers(rest, 6);
    if (!c) {
      return absl::InvalidArgumentError(
          absl::StrCat("--region ", text, ": a box is box:x0,y0,z0,x1,y1,z1 (two opposite corners, 6 numbers)"));
    }
    const std::vector<double>& v = *c;
    r.kind = RegionSpec::kBox;
    r.low = {std::min(v[0], v[3]), std::min(v[1], v[4]), std::min(v[2], v[5])};
    r.high = {std::max(v[0], v[3]), std::max(v[1], v[4]), std::max(v[2], v[5])};
    return r;
  }
  if (kind == "sphere") {
    const std::optional<std::vector<double>> c = Numbers(rest, 4);
    if (!c || !((*c)[3] > 0.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--region ", text, ": a sphere is sphere:cx,cy,cz,r (centre and a radius above 0)"));
    }
    r.kind = RegionSpec::kSphere;
    r.centre = {(*c)[0], (*c)[1], (*c)[2]};
    r.radius = (*c)[3];
    return r;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("--region ", text, ": give box:x0,y0,z0,x1,y1,z1 or sphere:cx,cy,cz,r"));
}

absl::Status CheckStrengthOptions(const StrengthOptions& o) {
  if (!o.weight.empty()) {
    if (absl::StatusOr<WeightSpec> w = ParseWeight(o.weight); !w.ok()) return w.status();
  }
  if (!o.region.empty()) {
    if (absl::StatusOr<RegionSpec> r = ParseRegion(o.region); !r.ok()) return r.status();
  }
  if (o.outside && o.region.empty()) return absl::InvalidArgumentError("--outside needs a --region to invert");
  if (!(o.falloff >= 0.0) || !std::isfinite(o.falloff)) {
    return absl::InvalidArgumentError(absl::StrCat("--falloff must be a finite distance >= 0, got ", o.falloff));
  }
  if (o.falloff > 0.0 && o.region.empty()) {
    return absl::InvalidArgumentError("--falloff needs a --region whose edge it softens");
  }
  return absl::OkStatus();
}

double SignedDistance(const RegionSpec& region, const Vec3& p) {
  if (region.kind == RegionSpec::kSphere) return Norm(p - region.centre) - region.radius;
  // Per axis, how far p lies outside the box's slab (negative inside it).
  const Vec3 centre = (region.low + region.high) * 0.5, half = (region.high - region.low) * 0.5;
  const Vec3 q = {std::abs(p.x - centre.x) - half.x, std::abs(p.y - centre.y) - half.y,
                  std::abs(p.z - centre.z) - half.z};
  const Vec3 out = {std::max(q.x, 0.0), std::max(q.y, 0.0), std::max(q.z, 0.0)};
  return Norm(out) + std::min(std::max({q.x, q.y, q.z}), 0.0);
}

absl::StatusOr<std::vector<float>> VertexStrength(const Mesh& mesh, const StrengthOptions& o) {
  if (absl::Status s = CheckStrengthOptions(o); !s.ok()) return s;
  if (!o.any()) return std::vector<float>{};
  std::vector<float> strength(mesh.positions.size(), 1.0f);
  if (!o.weight.empty()) {
    absl::StatusOr<std::vector<float>> w = WeightValues(mesh, *ParseWeight(o.weight), "--weight " + o.weight);
    if (!w.ok()) return w.status();
    strength = *std::move(w);
  }
  if (!o.region.empty()) {
    const RegionSpec region = *ParseRegion(o.region);
    for (size_t v = 0; v < strength.size(); ++v) {
      const double d = SignedDistance(region, mesh.positions[v]);
      // 1 in the region, 0 beyond the falloff, a smoothstep between.
      double inside = d <= 0.0 ? 1.0 : o.falloff > 0.0 ? 1.0 - SmoothStep(d / o.falloff) : 0.0;
      if (o.outside) inside = 1.0 - inside;
      strength[v] = static_cast<float>(strength[v] * inside);
    }
  }
  if (!o.fixed.empty()) {
    if (absl::Status s = HoldFixed(o.fixed, strength); !s.ok()) return s;
  }
  return strength;
}

std::vector<Rgb> StrengthColours(const std::vector<float>& strength) {
  constexpr std::array<double, 3> kZero = {180, 180, 180}, kOne = {235, 125, 35};
  std::vector<Rgb> colours(strength.size());
  for (size_t v = 0; v < strength.size(); ++v) {
    auto mix = [s = static_cast<double>(strength[v])](double a, double b) {
      return static_cast<uint8_t>(std::lround(a + (b - a) * s));
    };
    colours[v] = {mix(kZero[0], kOne[0]), mix(kZero[1], kOne[1]), mix(kZero[2], kOne[2])};
  }
  return colours;
}

}  // namespace meshsmooth::client
