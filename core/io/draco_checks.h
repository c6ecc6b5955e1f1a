// Internal to core: what the Draco functions check on what Draco's decoder lets through and on
// what its encoders are given (draco_codec.h says what is refused and why).
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/draco_codec.h"
#include "core/vec3.h"
#include "draco/mesh/mesh.h"

namespace meshsmooth {

// InvalidArgument naming the point or vertex (`what` `index`, e.g. "point 7") when a coordinate
// is not finite or above kMaxCoordinate in magnitude.
absl::Status CheckCoordinates(const Vec3& p, const char* what, int64_t index);

// InvalidArgument when Draco's sequential encoding would hold more than 3 of `points` a face of
// `faces` (its decoder takes that for corrupt data and refuses the bytes).
absl::Status CheckSequentialPoints(int64_t points, int64_t faces);

// InvalidArgument for quantization bits or a speed out of range.
absl::Status CheckDracoOptions(const DracoOptions& options);

// InvalidArgument when the values of `positions` (float32 xyz, all of them, as Draco's
// quantizer measures them) span less than kMinQuantizedExtent but more than nothing.
absl::Status CheckQuantizedExtent(const draco::PointAttribute& positions);

// What Draco's decoder lets through but no reader of the mesh may meet (coordinates are checked
// where they are read, CheckCoordinates): more points than an int32 holds, more than 256
// attributes, no or several
// POSITION attributes (Draco's Edgebreaker encoder crashes on a second one), an attribute whose
// values do not fit its buffer or that has no value for some point, a face naming a point past
// the point count (Draco's encoders then read past the attributes' buffers). InvalidArgument
// naming the attribute, point or face.
absl::Status CheckDracoLayout(const draco::Mesh& dm);

// InvalidArgument naming `what` unless `a` holds integers or floating-point numbers: Draco's
// ConvertValue() reads a DT_BOOL value as a bool, undefined for any byte but 0 and 1, which
// a corrupt file has.
absl::Status CheckNumericValues(const draco::PointAttribute& a, std::string_view what);

// Draco's Edgebreaker decoder sizes its connectivity tables (3 corners a face, an entry a
// vertex) from counts at the head of the bitstream, before it reads the symbols that should
// back them: a 1.4 KB file can declare 235 million faces, 2.8 GB. Those counts are read here
// first (Draco's header and metadata decoders, then the counts, in every bitstream version):
// ResourceExhausted when a file declares more than 2 * `max_vertices` vertices or 4 *
// `max_vertices` faces (a mesh within the limit has about 2 faces a vertex; the room is for
// high genus and split non-manifold vertices). InvalidArgument, whatever the limit, when the
// counts are beyond what the file's size can encode (about 1,000 faces a byte; the densest real
// encoding holds under 70). OK for the sequential method, whose counts
// Draco bounds by the data's size, and for bytes too short to hold the counts (the decoder
// refuses those). On success, the counts declared (Edgebreaker), or nullopt.
struct DeclaredSizes {
  int64_t faces = 0;
  int64_t vertices = 0;
};
absl::StatusOr<std::optional<DeclaredSizes>> CheckDeclaredEdgebreakerSizes(std::string_view bytes,
                                                                           int64_t max_vertices);

// The largest block of memory Draco's decoder may allocate for one input: more, and the data is
// refused as corrupt (core/io/allocation_limit.h says why). Edgebreaker data declares its faces and
// vertices before any table is sized: kDracoDecodeFloorBytes plus kDracoDecodeBytesPerElement
// per face and vertex, room for attributes of 255 components of 8 bytes on every corner. Other
// data (sequential: Draco bounds its counts by the bytes): kDracoDecodeBytesPerByte per byte.
// docs/reliability.md ("Draco's decoding, bounded") has the largest blocks valid files need.
inline constexpr int64_t kDracoDecodeFloorBytes = int64_t{8} << 20;
inline constexpr int64_t kDracoDecodeBytesPerElement = int64_t{8} << 10;
inline constexpr int64_t kDracoDecodeBytesPerByte = int64_t{64} << 10;
int64_t LargestDracoDecodeBlock(size_t bytes, const std::optional<DeclaredSizes>& declared);

// Edgebreaker leaves out faces with a repeated point and the points no other face uses: marks
// the points some face of three distinct points uses (every face index < num_points).
std::vector<uint8_t> PointsEdgebreakerKeeps(const draco::Mesh& dm);

// The InvalidArgument for an Edgebreaker output that would drop `dropped` vertices.
absl::Status EdgebreakerDropsError(int64_t dropped);

}  // namespace meshsmooth
