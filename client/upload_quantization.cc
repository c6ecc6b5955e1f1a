#include "client/upload_quantization.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/io/draco_codec.h"

namespace meshsmooth::client {
namespace {

// Mean length of the faces' edges (each interior edge counted from both its faces), over the
// faces whose indices are all in range; 0 without one.
double MeanFaceEdge(const Mesh& mesh) {
  const int32_t n = mesh.num_vertices();
  double sum = 0.0;
  int64_t edges = 0;
  for (const Triangle& t : mesh.triangles) {
    if (IndexOutOfRange(t, n)) continue;
    for (int k = 0; k < 3; ++k) sum += Norm(mesh.positions[t[(k + 1) % 3]] - mesh.positions[t[k]]);
    edges += 3;
  }
  return edges > 0 ? sum / static_cast<double>(edges) : 0.0;
}

// float32's unit in the last place at magnitude `x` (> 0).
double Float32Ulp(double x) { return std::ldexp(1.0, std::ilogb(static_cast<float>(x)) - 23); }

}  // namespace

absl::StatusOr<double> ParseUploadQuantization(const std::string& text) {
  if (text.empty()) return kDefaultUploadQuantization;
  double value = 0.0;
  const bool number = absl::SimpleAtod(text, &value);
  if (!number || !(value > 0.0) || value > kMaxUploadQuantization) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--quantize-upload takes the bound as a fraction of the mean edge length, above 0 and at most ",
        kMaxUploadQuantization, " (default ", kDefaultUploadQuantization, " when given alone); got '", text, "'",
        number ? ""
               : " (given alone before the input file, the flag takes the file as its value: write it after "
                 "the input, or --quantize-upload=FRACTION)"));
  }
  return value;
}

UploadQuantization ChooseUploadQuantization(const Mesh& mesh, double fraction) {
  UploadQuantization q;
  q.fraction = fraction;
  q.mean_edge = MeanFaceEdge(mesh);
  const double wanted = fraction * q.mean_edge;
  if (mesh.positions.empty() || !(wanted > 0.0) || !std::isfinite(wanted)) return q;
  double lo[3], hi[3];
  for (int c = 0; c < 3; ++c) lo[c] = std::numeric_limits<double>::infinity(), hi[c] = -lo[c];
  double largest = 0.0;
  for (const Vec3& p : mesh.positions) {
    const double v[3] = {p.x, p.y, p.z};
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], v[c]);
      hi[c] = std::max(hi[c], v[c]);
      largest = std::max(largest, std::abs(v[c]));
    }
  }
  // Draco's grid spans the largest extent over x, y, z.
  double extent = 0.0;
  for (int c = 0; c < 3; ++c) extent = std::max(extent, hi[c] - lo[c]);
  if (extent < kMinQuantizedExtent) return q;
  // The float32 steps of the encoder's input, its differences to the box's corner, the scaling to
  // the grid, the decoder's scaling back and its sum with the corner: 6 units in the last place
  // hold them all.
  const double rounding = 6.0 * Float32Ulp(std::max(largest, extent));
  for (int bits = 1; bits <= kMaxQuantizationBits; ++bits) {
    const double bound = extent / (std::ldexp(1.0, bits) - 1.0) / 2.0 + rounding;
    if (bound <= wanted) {
      q.bits = bits;
      q.bound = bound;
      return q;
    }
  }
  return q;
}

std::string DescribeUploadQuantization(const UploadQuantization& q) {
  if (q.bits == 0 && !(q.mean_edge > 0.0)) {
    return "upload sent lossless: the mesh has no edge of non-zero length to state the bound against";
  }
  if (q.bits == 0) {
    return absl::StrFormat(
        "upload sent lossless: no quantization of at most %d bits holds %g of the mean edge %.6g (float32 is coarser "
        "at these coordinates)",
        kMaxQuantizationBits, q.fraction, q.mean_edge);
  }
  return absl::StrFormat(
      "upload quantized to %d bits: each coordinate within %.6g of the input (%g of the mean edge %.6g)", q.bits,
      q.bound, q.fraction, q.mean_edge);
}

}  // namespace meshsmooth::client
