// The CLI's ways to give a per-vertex strength (JobSpec.strength_attribute): a PLY vertex
// property (--weight), a file of vertex indices held fixed (--fixed), a box or a sphere
// (--region, --outside) with a smooth edge (--falloff). The CLI computes the strength from the
// input mesh as read and sends it as a generic attribute named kStrengthAttribute.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/mesh.h"

namespace meshsmooth::client {

// The name of the attribute the CLI sends the strength in.
inline constexpr char kStrengthAttribute[] = "meshsmooth_strength";

// The flags as given on the command line; empty strings = not given.
struct StrengthOptions {
  std::string weight;  // PROP or PROP:LO,HI
  std::string fixed;   // FILE
  std::string region;  // box:x0,y0,z0,x1,y1,z1 or sphere:cx,cy,cz,r
  bool outside = false;
  double falloff = 0.0;  // mesh units
  bool any() const { return !weight.empty() || !fixed.empty() || !region.empty(); }
};

// --weight, parsed: a property and, optionally, the values mapped to 0 and 1.
struct WeightSpec {
  std::string property;
  std::optional<std::array<double, 2>> map;  // LO -> 0, HI -> 1, clamped
};

// --region, parsed.
struct RegionSpec {
  enum Kind { kBox, kSphere } kind = kBox;
  Vec3 low, high;  // a box's corners, low <= high on every axis
  Vec3 centre;
  double radius = 0.0;
};

absl::StatusOr<WeightSpec> ParseWeight(const std::string& text);
absl::StatusOr<RegionSpec> ParseRegion(const std::string& text);

// The flags' syntax and their combinations (--outside and --falloff need --region; --falloff
// is finite and >= 0), before any file is read: InvalidArgument naming the flag.
absl::Status CheckStrengthOptions(const StrengthOptions& o);

// The distance from `p` to the region's edge: negative inside, positive outside (a box's is 0
// on its faces and grows as the distance to the box outside it).
double SignedDistance(const RegionSpec& region, const Vec3& p);

// The strength of each vertex of `mesh` (positions as read, in the file's coordinates), the
// product of what the flags give: --weight's property mapped into [0, 1] (values outside it
// without a map are refused), the region's 1 inside and 0 outside (the other way round with
// --outside), with a smoothstep from the edge over --falloff outside the region, and 0 at
// --fixed's indices. Empty when no flag is given. InvalidArgument naming the flag for a
// property the mesh does not have, a value that is not a number, a file that cannot be read,
// and an index that is not one or out of range.
absl::StatusOr<std::vector<float>> VertexStrength(const Mesh& mesh, const StrengthOptions& o);

// Colours that show a strength in a picture (meshsmooth render): grey (the renderer's base colour)
// at 0, orange at 1, linear between.
std::vector<Rgb> StrengthColours(const std::vector<float>& strength);

}  // namespace meshsmooth::client
