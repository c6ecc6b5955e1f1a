// Coordinates far from the origin: survey and georeferenced scans (UTM metres, x ~ 5e5,
// y ~ 5e6) hold their precision in double, while the service works on float32 positions,
// whose spacing at 5e6 is 0.5. The CLI sends such a mesh relative to a local origin and adds
// the origin back to the result (the "global shift" of CloudCompare), and the service warns
// about a Draco upload whose float32 coordinates are already too coarse for its edges.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/vec3.h"

namespace meshsmooth {

// Coordinates at or above this magnitude are shifted (CloudCompare's default threshold).
inline constexpr double kLocalOriginMinCoordinate = 1e4;

// A Draco upload is warned about when float32's spacing at its largest coordinate exceeds
// this fraction of its mean edge length.
inline constexpr double kCoarseCoordinateFraction = 0.01;

// The origin to send `positions` relative to: zero when every finite coordinate is below
// kLocalOriginMinCoordinate in magnitude (so a mesh near the origin goes as it is, bit for
// bit), otherwise the centre of their bounding box rounded to whole units per axis. Non-finite
// coordinates are ignored; zero when there is no finite one.
Vec3 LocalOrigin(const std::vector<Vec3>& positions);

// Adds `offset` to every position (subtracting an origin: pass its negation).
void Translate(std::vector<Vec3>& positions, const Vec3& offset);

// The spacing of float32 values at the largest finite coordinate magnitude of `positions`
// (0 when there is none): the resolution float32 positions have there.
double Float32Spacing(const std::vector<Vec3>& positions);

// When float32's spacing at `positions`' largest coordinate exceeds kCoarseCoordinateFraction
// of `mean_edge`: a one-line warning that says by how much and how to avoid it. Nothing
// otherwise, and nothing when `mean_edge` is not positive.
std::optional<std::string> CoarseCoordinatesWarning(const std::vector<Vec3>& positions, double mean_edge);

}  // namespace meshsmooth
