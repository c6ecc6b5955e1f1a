// Triangle coverage on a pixel grid, shared by the shaded renderer (render.h) and the
// benchmark's range-scan simulator (bench/range_scan.h): which pixel centres a screen-space
// triangle covers, and their barycentric weights. Screen positions are snapped to 1/256 pixel
// so that the edge functions are exact integers: neighbouring faces then share their edges
// exactly and the fill rule covers every pixel centre once (no cracks, no double-drawn pixels).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>

namespace meshsmooth::raster {

inline constexpr int kSubBits = 8;
inline constexpr int64_t kSub = int64_t{1} << kSubBits;

// A corner on the screen in fixed point (kSubBits fractional bits); x grows to the right, y
// downward, pixel (x, y)'s centre at (x + 1/2, y + 1/2).
struct ScreenPoint {
  int64_t x = 0, y = 0;
};

// `pixels` (a screen coordinate) in fixed point.
inline int64_t ToFixed(double pixels) { return std::llround(pixels * static_cast<double>(kSub)); }

// Floor and ceiling of a / b for b > 0 and any sign of a.
inline int64_t FloorDiv(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
inline int64_t CeilDiv(int64_t a, int64_t b) { return -FloorDiv(-a, b); }

// Edge a->b owns the pixel centres exactly on it when this is true; for the same edge walked
// the other way (by the neighbouring face) it is false, so a shared edge is drawn once.
inline bool OwnsEdge(const ScreenPoint& a, const ScreenPoint& b) {
  const int64_t dy = b.y - a.y;
  return dy > 0 || (dy == 0 && b.x < a.x);
}

// Calls visit(index, l0, l1, l2) for every pixel centre of the width x height grid that the
// triangle p0 p1 p2 covers (either winding: both are drawn), row by row; index = y * width + x
// and l0, l1, l2 are the centre's barycentric weights of p0, p1 and p2 on the screen. A
// triangle edge-on or smaller than the snapping grid covers nothing.
template <typename Visit>
void ForEachCoveredPixel(int width, int height, ScreenPoint p0, ScreenPoint p1, ScreenPoint p2, Visit&& visit) {
  int64_t area = (p1.x - p0.x) * (p2.y - p0.y) - (p1.y - p0.y) * (p2.x - p0.x);
  if (area == 0) return;
  const bool swapped = area < 0;  // both windings with the same (positive) edge functions
  if (swapped) {
    std::swap(p1, p2);
    area = -area;
  }
  const int64_t half = kSub / 2;  // pixel x's centre is at x * kSub + half
  const int64_t x_lo = std::max<int64_t>(0, CeilDiv(std::min({p0.x, p1.x, p2.x}) - half, kSub));
  const int64_t x_hi = std::min<int64_t>(width - 1, FloorDiv(std::max({p0.x, p1.x, p2.x}) - half, kSub));
  const int64_t y_lo = std::max<int64_t>(0, CeilDiv(std::min({p0.y, p1.y, p2.y}) - half, kSub));
  const int64_t y_hi = std::min<int64_t>(height - 1, FloorDiv(std::max({p0.y, p1.y, p2.y}) - half, kSub));
  if (x_lo > x_hi || y_lo > y_hi) return;  // covers no pixel centre

  // Edge k is opposite corner k; its function is corner k's barycentric weight times area.
  const ScreenPoint* v[3] = {&p0, &p1, &p2};
  int64_t e_row[3], step_x[3], step_y[3], bias[3];
  const int64_t px = x_lo * kSub + half, py = y_lo * kSub + half;
  for (int k = 0; k < 3; ++k) {
    const ScreenPoint& a = *v[(k + 1) % 3];
    const ScreenPoint& b = *v[(k + 2) % 3];
    e_row[k] = (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
    step_x[k] = -(b.y - a.y) * kSub;
    step_y[k] = (b.x - a.x) * kSub;
    bias[k] = OwnsEdge(a, b) ? 0 : 1;  // e >= bias: e > 0, or e == 0 on an owned edge
  }
  const double inv_area = 1.0 / static_cast<double>(area);
  for (int64_t y = y_lo; y <= y_hi; ++y) {
    int64_t e0 = e_row[0], e1 = e_row[1], e2 = e_row[2];
    size_t index = static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x_lo);
    for (int64_t x = x_lo; x <= x_hi; ++x, ++index) {
      if (e0 >= bias[0] && e1 >= bias[1] && e2 >= bias[2]) {
        const double l0 = static_cast<double>(e0) * inv_area, l1 = static_cast<double>(e1) * inv_area,
                     l2 = static_cast<double>(e2) * inv_area;
        if (swapped) {
          visit(index, l0, l2, l1);
        } else {
          visit(index, l0, l1, l2);
        }
      }
      e0 += step_x[0];
      e1 += step_x[1];
      e2 += step_x[2];
    }
    for (int k = 0; k < 3; ++k) e_row[k] += step_y[k];
  }
}

}  // namespace meshsmooth::raster
