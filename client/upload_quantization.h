// `--quantize-upload`: an upload whose positions Draco quantizes to a bound the user states as a
// fraction of the input's mean edge length, for a mesh too large to send losslessly (a lossless
// upload is about 36 bytes a vertex). The job's result comes back as the service encodes it
// (lossless float32 by default): only the input the service smooths is rounded.
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "core/mesh.h"

namespace meshsmooth::client {

// --quantize-upload without a value: a thousandth of the mean edge.
inline constexpr double kDefaultUploadQuantization = 0.001;
// The coarsest bound --quantize-upload takes, in mean edge lengths: beyond, the quantization
// is noise of its own that the smoothing would have to take out.
inline constexpr double kMaxUploadQuantization = 0.1;

// --quantize-upload's value: empty (the flag alone) is kDefaultUploadQuantization; otherwise a
// number in (0, kMaxUploadQuantization]. InvalidArgument naming the flag for anything else
// (not a number, <= 0, NaN, an infinity, above the maximum).
absl::StatusOr<double> ParseUploadQuantization(const std::string& text);

// How an upload's positions were quantized.
struct UploadQuantization {
  double fraction = 0.0;   // asked for, in mean edge lengths; 0 = not asked
  double mean_edge = 0.0;  // the input's mean edge length (over its faces' edges)
  // Draco's position quantization bits; 0 = the upload went lossless, since no quantization of
  // at most kMaxQuantizationBits holds the bound (a bound finer than float32 at the mesh's
  // coordinates, or a mesh without an edge of non-zero length).
  int bits = 0;
  // With `bits`: the largest difference, in mesh units, between a coordinate as read (relative to
  // the upload's origin) and as the service decodes it; at most fraction * mean_edge.
  double bound = 0.0;
};

// The coarsest quantization of `mesh`'s positions (as the encoder receives them: relative to the
// upload's origin) whose bound is at most `fraction` * its mean edge. Draco rounds each
// coordinate to a grid of (2^bits - 1) steps over the largest extent of the bounding box, so a
// coordinate moves by at most half a step, plus float32's rounding at the mesh's coordinates
// (counted as 6 float32 units in the last place of the largest coordinate or extent).
UploadQuantization ChooseUploadQuantization(const Mesh& mesh, double fraction);

// The summary's line, e.g. "upload quantized to 21 bits: each coordinate within 0.000412 of the
// input (0.001 of the mean edge 0.5)"; for bits 0 says the upload went lossless and why.
std::string DescribeUploadQuantization(const UploadQuantization& q);

}  // namespace meshsmooth::client
