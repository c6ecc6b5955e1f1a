// Texture coordinates through Draco's glTF transcoder, bit for bit.
//
// Draco's glTF reader stores a texture coordinate's v as float32(1 - v) and its writer writes
// float32(1 - that) back: for v below 0.5 the two roundings change v by up to a float32 step
// (569 of 1,839 coordinates of a textured scan). Smoothing never changes a texture coordinate,
// so each value the writer wrote is the round trip of one the input held: TexcoordOriginals
// reads the input file's own values and RestoreTexcoords writes them back over their round trips
// in the output file, where the round trip names one original (two originals with one round trip
// are left as written).
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace meshsmooth {

// Per float32 bit pattern of a round trip, the bits of the original v it came from; 0xffffffff
// for a round trip two originals share. Values the round trip keeps are left out: empty when
// Draco changes none.
struct TexcoordOriginals {
  std::unordered_map<uint32_t, uint32_t> original_of;
};

// The v of every float VEC2 TEXCOORD_n accessor of every primitive of the .gltf or .glb at
// `path` (sparse and integer accessors are not read: their values come back as Draco writes
// them). InvalidArgument for a file whose JSON, buffers or accessors do not hold together.
absl::StatusOr<TexcoordOriginals> ReadTexcoordOriginals(const std::string& path);

// Rewrites, in the .gltf (its buffer files) or .glb at `path`, every TEXCOORD_n v that is the
// round trip of one original in `originals` with that original. Returns how many were
// rewritten; InvalidArgument as above, Internal when a file cannot be written.
absl::StatusOr<int64_t> RestoreTexcoords(const std::string& path, const TexcoordOriginals& originals);

}  // namespace meshsmooth
