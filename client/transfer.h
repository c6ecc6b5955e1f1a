// Between a mesh file and the service: what the CLI uploads for an input file and how it
// writes the result back, keeping what the service does not change (the input's texture
// coordinates, colours, properties and OBJ material lines, its coordinates' magnitude and
// precision) and naming whatever the output cannot hold.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/strength.h"
#include "client/upload_quantization.h"
#include "core/io/draco_codec.h"
#include "core/io/gltf.h"
#include "core/mesh.h"
#include "core/vec3.h"

namespace meshsmooth::client {

struct Upload {
  std::string input;  // the path (or builtin:NAME) it came from
  std::string draco;  // what is sent
  bool draco_input = false;
  // The input as read: its triangles, colours and attributes, written back around the result's
  // positions (vertex i of the result is vertex i of the input), and its positions as sent
  // (relative to `origin`, in double): a vertex the job did not move comes back with these, not
  // with the float32 the service holds.
  Mesh kept;
  int32_t num_vertices = 0;
  // Positions were sent relative to this origin (LocalOrigin): zero for a mesh near the
  // origin, the rounded centre of a georeferenced one. Added back to the result.
  Vec3 origin;
  bool double_positions = false;      // write PLY coordinates as double
  std::vector<std::string> warnings;  // about the input, one sentence each
  std::vector<std::string> dropped;   // what the input held that does not come back, one phrase each
  // A .gltf/.glb input: the scene, whose primitives' points were sent as one mesh.
  std::shared_ptr<GltfScene> gltf;
  // The upload carries a per-vertex strength, the attribute kStrengthAttribute (client/strength.h).
  bool strength = false;
  // For a job run in memory (no `draco`): the strength's values, one per vertex of `kept`.
  std::vector<float> strength_values;
  // --quantize-upload: how `draco`'s positions were quantized (fraction 0: lossless).
  UploadQuantization quantization;
};

// True for a path whose extension is .gltf or .glb (case-insensitive).
bool IsGltfPath(const std::string& path);

// Draco input goes as it is (all its attributes travel along); a glTF scene goes as the
// points of all its triangle primitives (GltfScene::surface); anything else is read in
// double, moved to its local origin and encoded losslessly and sequentially with its
// attributes (texture coordinates, normals, colours, vertex properties: EncodeDraco), so
// vertex i of the result is vertex i of the input. Without `with_attributes` (an output other
// than .drc, which WriteResult writes from the input's own attributes around the result's
// positions) a non-Draco input sends its positions and faces only: the same vertices, so the
// same result, without encoding, sending and decoding what does not come back from the
// service. The reader's errors when the input cannot be read. A glTF input is first read and
// written in a child process (GltfScene::ReadInChildFirst; Draco-compressed too with
// `gltf_draco`, the output the CLI will write): call this before starting threads.
// `strength` (VertexStrength, from the mesh as read) goes along as the generic attribute
// kStrengthAttribute (replacing an input property of that name), whatever `with_attributes`;
// InvalidArgument naming the flag for a Draco or glTF input, which the CLI does not read as a
// mesh of its own, and for VertexStrength's errors.
//
// `in_memory` (a mesh file or builtin:NAME, without `with_attributes`): the mesh goes to a job in
// this process as it is (server::MeshUpload over `kept`, the strength in `strength_values`)
// instead of being encoded; the same checks as the encoder's (CheckPositionsEncodable), with
// the same errors, so that the local run fails where the upload would.
//
// `quantize_upload` above 0 (--quantize-upload, a mesh file or builtin:NAME going to the service):
// the positions are quantized by Draco so that no coordinate moves more than that fraction of the
// mean edge length (ChooseUploadQuantization; what was done in `quantization`); every other
// attribute goes lossless. InvalidArgument for a .drc or glTF input, which goes as it is.
absl::StatusOr<Upload> PrepareUpload(const std::string& input, bool with_attributes = true, bool gltf_draco = false,
                                     const StrengthOptions& strength = {}, bool in_memory = false,
                                     double quantize_upload = 0.0);

// A mesh in memory (positions in double, in its own coordinates; the Python package's input)
// made into an upload as PrepareUpload makes a mesh file's: faces naming a vertex that does not
// exist left out with a warning, the positions moved to their local origin, `strength` (empty,
// or one value per vertex) as the attribute kStrengthAttribute; kept for a job in memory with
// `in_memory`, else encoded bare (positions, faces and strength: the attributes stay in `kept`
// and come back with ResultMesh). InvalidArgument for a strength of another length and for what
// the encoder refuses (CheckPositionsEncodable).
absl::StatusOr<Upload> UploadMesh(Mesh mesh, std::vector<float> strength, bool in_memory);

// OK when `output` can be written once the job is done: a format the CLI writes (.obj, .ply,
// .off, .stl, .drc, and .gltf/.glb for a glTF input) in a folder that exists and is writable,
// and not a folder itself. InvalidArgument otherwise, naming what is wrong: checked before the
// upload, so that a typo does not cost the job.
absl::Status CheckOutputPath(const std::string& output);

// Writes `result` (the service's Draco bytes) to `output` in the format its extension names:
// Draco bytes as they came (decoded, moved back by the upload's origin and encoded again with
// `draco` when there is one: .drc holds float32, which the warning says), anything else decoded
// and moved back by the upload's origin, each vertex the job did not move at its position as
// read (exactly, in the formats that hold double: .obj, .off, double .ply), with
// the input's attributes, normals recomputed from the smoothed positions, the ridge labels
// (`ridges`) as vertex colours, PLY coordinates in double when the input had them or was
// shifted. An OBJ output's `mtllib` lines are rewritten to reach the input's material files
// from the output's folder. What the output cannot hold (or cannot find: a material file, a
// texture image) is appended to `dropped`, one phrase each. Errors about the result itself
// start with "the result: ". A glTF input is written as the same scene with the smoothed
// positions (GltfScene::Write; primitives Draco-compressed when `gltf_draco`) and only to
// .gltf or .glb: InvalidArgument otherwise, as for glTF output of another input. The input's
// triangles and attributes are moved out of `upload.kept` into the output (not copied): one
// WriteResult per upload.
absl::Status WriteResult(Upload& upload, const std::string& result, const std::string& output, bool ridges,
                         std::vector<std::string>* dropped = nullptr, bool gltf_draco = false,
                         const DracoOptions& draco = {});

// The result's points, one per vertex of the upload (relative to its origin, the float32 the
// service sent), and its ridge labels, one per vertex, when `ridges`.
struct ResultPoints {
  std::vector<Vec3> points;
  std::vector<uint8_t> labels;
};

// The points of `result` (the service's Draco bytes for an upload of a mesh file, builtin:NAME or
// UploadMesh: not a .drc or glTF input), as WriteResult reads them. Errors about the result
// itself start with "the result: ".
absl::StatusOr<ResultPoints> DecodeResultPoints(const Upload& upload, const std::string& result, bool ridges);

// The result mesh as WriteResultPoints writes it, in the input's coordinates: `points` (one per
// vertex of the upload) moved back by the upload's origin, each vertex the job did not move at its
// position as read, with the input's triangles and attributes (moved out of `upload.kept`), normals
// recomputed from the smoothed positions. InvalidArgument for a .drc or glTF upload and for a
// count of points other than the upload's vertices.
absl::StatusOr<Mesh> ResultMesh(Upload& upload, std::vector<Vec3> points);

// WriteResult for a job run in memory on an upload of a mesh file or builtin:NAME: `points`, one
// per vertex of the upload, are the result's positions (the float32 the service would send) and
// `labels` (when `ridges`) its ridge labels, one per vertex; everything else as WriteResult with
// an output other than .drc and glTF (InvalidArgument for those).
absl::Status WriteResultPoints(Upload& upload, std::vector<Vec3> points, const std::vector<uint8_t>& labels,
                               const std::string& output, bool ridges, std::vector<std::string>* dropped = nullptr);

}  // namespace meshsmooth::client
