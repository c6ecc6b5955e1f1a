// Internal to core/io: the steps the Draco functions of draco_codec.h share. Bytes to a checked
// draco::Mesh (draco_decode.cc) and a draco::Mesh to bytes (draco_encode.cc), a decoded mesh's
// points as a Mesh, and the attribute names that Draco keeps in its metadata
// (draco_metadata.cc).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/draco_codec.h"
#include "core/mesh.h"
#include "core/vec3.h"
#include "draco/mesh/mesh.h"

namespace meshsmooth {

// Decodes a Draco triangle mesh with clear errors; the sizes it declares are checked before
// Draco allocates for them (CheckDeclaredEdgebreakerSizes), its layout after (CheckDracoLayout).
// InvalidArgument as DecodeDraco(); ResourceExhausted as DracoMesh::Decode() for `max_vertices`.
absl::StatusOr<std::unique_ptr<draco::Mesh>> DecodeToDraco(std::string_view bytes, int64_t max_vertices);

// The position of every point of `dm`, as doubles (InvalidArgument for a point without one or
// with a coordinate out of range).
absl::StatusOr<std::vector<Vec3>> PointPositions(const draco::Mesh& dm);

// Positions of every point, and faces over points (PointPositions' errors).
absl::StatusOr<Mesh> PointMesh(const draco::Mesh& dm);

// Draco's encoder run on `dm` with `options`. InvalidArgument for options out of range, a
// sequential encoding of more than 3 points a face (Draco's decoder would refuse it), quantized
// positions spanning less than kMinQuantizedExtent, and Draco's own refusals;
// ResourceExhausted when Draco's encoder runs out of memory.
absl::StatusOr<std::string> EncodeWithOptions(const draco::Mesh& dm, const DracoOptions& options);

// EncodeWithOptions on a mesh of the caller's that is not needed afterwards: `dm` is freed as
// soon as Draco's encoder is done with it, before its bytes are copied out (a large job's peak
// then holds the encoded bytes twice, but not the Draco mesh beside them).
absl::StatusOr<std::string> EncodeReleasing(std::unique_ptr<draco::Mesh> dm, const DracoOptions& options);

// A Draco mesh of `mesh`'s float32 positions, one point a vertex, and its faces with every index
// in range: what EncodeDraco() encodes for a mesh without attributes.
std::unique_ptr<draco::Mesh> PositionsAndFacesMesh(const Mesh& mesh);

// The name of attribute `id` (index in `dm`): its metadata entry "name", how Draco files label
// generic data. False when it has none.
bool AttributeName(const draco::Mesh& dm, int32_t id, std::string* name);

// The index of the first attribute whose name (AttributeName) is `name`, or -1.
int NamedAttributeId(const draco::Mesh& dm, std::string_view name);

// Gives attribute `id` the metadata entry "name" = `name`.
void NameAttribute(draco::Mesh& dm, int id, const std::string& name);

// A unique id above every attribute's and every attribute metadata's: Draco numbers a new
// attribute's unique id by its index, which after a deletion can be the id of an attribute
// still present (or of metadata left behind), and the metadata would then name the wrong one.
uint32_t UnusedAttributeUniqueId(const draco::Mesh& dm);

}  // namespace meshsmooth
