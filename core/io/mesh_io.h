// Mesh files: OBJ, PLY (ASCII and binary), OFF, STL and Draco (.drc), chosen by extension.
//
// Why meshsmooth parses OBJ/PLY/OFF/STL itself instead of calling OpenMesh's readers: those
// readers drop degenerate faces and split vertices at non-manifold edges, and
// the mesh that is validated, smoothed and returned must be the one the user sent, index for
// index. Here every vertex and every face of the file is kept in file order; polygons are
// fanned into triangles (counted in ReadInfo). OpenMesh's readers serve as the cross-check in
// the tests. What each path keeps:
//   OBJ, OFF, PLY, DRC (sequential)  vertex and face order kept.
//   STL                              a triangle soup: corners are welded by exact position in
//                                    order of first appearance; no other order exists.
//   DRC (Edgebreaker)                Draco reorders vertices and faces; see draco_codec.h.
// Text formats are written with the shortest decimal form that reads back to the same
// double; binary PLY and STL store float32, so float inputs round-trip exactly (PLY stores
// double x, y, z when WriteOptions::ply_double asks, and the reader says when a file had them).
// Vertex colours (Mesh::colors) are read from and written to PLY (`red green blue` uchar
// properties; float channels in 0..1 are scaled on reading; alpha is a vertex property like any
// other) and OBJ (`v x y z r g b`, 0..1). Texture coordinates and normals per corner: OBJ `vt`,
// `vn` and `f v/vt/vn`; PLY per vertex (`s t` or `texture_u texture_v`, `nx ny nz`) or per face
// (`texcoord` lists, MeshLab's per-wedge UVs). Named vertex properties: PLY. OBJ material and
// group lines: OBJ. OFF and STL hold positions and faces only. What a reader cannot hold is
// named in ReadInfo::dropped; never an error.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/draco_codec.h"
#include "core/mesh.h"

namespace meshsmooth {

enum class MeshFormat { kObj, kPly, kOff, kStl, kDraco };

// The format named by a path's extension (case-insensitive); InvalidArgument otherwise.
absl::StatusOr<MeshFormat> FormatFromPath(std::string_view path);

// What a reader noticed besides the mesh itself.
struct ReadInfo {
  int64_t polygons_fanned = 0;    // faces with more than 3 corners, split into a fan
  int64_t welded_corners = 0;     // STL: corners merged with an earlier identical position
  bool double_positions = false;  // PLY: x, y or z declared double (write them back as double)
  // What the file held that the Mesh cannot, one phrase each ("3 OBJ line elements (l)"), in
  // the order met; empty when everything was kept.
  std::vector<std::string> dropped;
};

// Parses a whole file held in memory. InvalidArgument with the line or byte position for
// malformed data; never crashes on arbitrary bytes.
absl::StatusOr<Mesh> ParseMesh(std::string_view data, MeshFormat format, ReadInfo* info = nullptr);

// Reads a file; ReadFileBytes' errors (NotFound for a missing file) when it cannot be read.
absl::StatusOr<Mesh> ReadMesh(const std::string& path, ReadInfo* info = nullptr);

struct WriteOptions {
  bool ply_binary = true;   // binary little-endian PLY (exact float32) or ASCII PLY
  bool ply_double = false;  // PLY x, y, z as double (exact doubles) rather than float
  DracoOptions draco;       // for .drc
};

// Serialises to bytes in `format`. InvalidArgument for PLY when the mesh has colours but not
// one per vertex.
absl::StatusOr<std::string> SerializeMesh(const Mesh& mesh, MeshFormat format, const WriteOptions& options = {});

// Writes a file in the format its extension names.
absl::Status WriteMesh(const std::string& path, const Mesh& mesh, const WriteOptions& options = {});

}  // namespace meshsmooth
