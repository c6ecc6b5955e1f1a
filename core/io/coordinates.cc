#include "core/io/coordinates.h"

#include <cmath>

#include "absl/strings/str_format.h"

namespace meshsmooth {
namespace {

double LargestMagnitude(const std::vector<Vec3>& positions) {
  double largest = 0.0;
  for (const Vec3& p : positions) {
    for (double c : {p.x, p.y, p.z}) {
      if (std::isfinite(c)) largest = std::fmax(largest, std::fabs(c));
    }
  }
  return largest;
}

}  // namespace

Vec3 LocalOrigin(const std::vector<Vec3>& positions) {
  if (LargestMagnitude(positions) < kLocalOriginMinCoordinate) return {};
  BoundingBox box;
  for (const Vec3& p : positions) {
    if (IsFinite(p)) box.Add(p);
  }
  if (box.empty()) return {};
  // Whole units: the shift is a number a user can read in the output and subtract by hand.
  return {std::round(0.5 * (box.lo.x + box.hi.x)), std::round(0.5 * (box.lo.y + box.hi.y)),
          std::round(0.5 * (box.lo.z + box.hi.z))};
}

void Translate(std::vector<Vec3>& positions, const Vec3& offset) {
  for (Vec3& p : positions) p += offset;
}

double Float32Spacing(const std::vector<Vec3>& positions) {
  const double largest = LargestMagnitude(positions);
  if (largest == 0.0) return 0.0;
  const float f = static_cast<float>(largest);
  return static_cast<double>(std::nextafter(f, HUGE_VALF)) - static_cast<double>(f);
}

std::optional<std::string> CoarseCoordinatesWarning(const std::vector<Vec3>& positions, double mean_edge) {
  if (!(mean_edge > 0.0)) return std::nullopt;
  const double spacing = Float32Spacing(positions);
  if (!(spacing > kCoarseCoordinateFraction * mean_edge)) return std::nullopt;
  return absl::StrFormat(
      "coordinates reach %.6g, where float32 steps by %.3g (%.3g mean edges): the positions were rounded "
      "that coarsely before smoothing; send them relative to a local origin near the mesh (or give the "
      "meshsmooth CLI the .obj/.ply in full precision: it shifts them itself)",
      LargestMagnitude(positions), spacing, spacing / mean_edge);
}

}  // namespace meshsmooth
