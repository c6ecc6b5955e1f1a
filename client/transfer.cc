#include "client/transfer.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/strip.h"
#include "client/inputs.h"
#include "core/attributes.h"
#include "core/features/ridges.h"
#include "core/io/coordinates.h"
#include "core/io/draco_codec.h"
#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/mesh.h"

namespace meshsmooth::client {
namespace {

namespace fs = std::filesystem;

// Leaves out the triangles for which `drop(t)` holds, with their corner attributes, and keeps
// each OBJ directive before the same following triangle.
template <typename Drop>
void DropTriangles(Mesh& mesh, const Drop& drop) {
  std::vector<int32_t> kept_before(mesh.triangles.size() + 1, 0);
  size_t out = 0;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    kept_before[t] = static_cast<int32_t>(out);
    if (drop(mesh.triangles[t])) continue;
    for (CornerAttribute* a : {&mesh.uvs, &mesh.normals}) {
      if (a->corners.size() != 3 * mesh.triangles.size()) continue;
      for (int k = 0; k < 3; ++k) a->corners[3 * out + k] = a->corners[3 * t + k];
    }
    mesh.triangles[out++] = mesh.triangles[t];
  }
  kept_before[mesh.triangles.size()] = static_cast<int32_t>(out);
  for (CornerAttribute* a : {&mesh.uvs, &mesh.normals}) {
    if (a->corners.size() == 3 * mesh.triangles.size()) a->corners.resize(3 * out);
  }
  for (ObjDirective& d : mesh.obj_directives) {
    d.before_triangle = kept_before[std::clamp<size_t>(d.before_triangle, 0, mesh.triangles.size())];
  }
  mesh.triangles.resize(out);
}

// The file names an `.mtl` file's texture statements (map_Kd, bump, ...) name: the last token
// of each, after the options.
std::vector<std::string> TextureFiles(const std::string& mtl) {
  std::vector<std::string> files;
  std::ifstream in(mtl);
  std::string line;
  while (std::getline(in, line)) {
    absl::string_view rest = absl::StripAsciiWhitespace(line);
    const size_t space = rest.find_first_of(" \t");
    if (space == absl::string_view::npos) continue;
    const absl::string_view key = rest.substr(0, space);
    if (!absl::StartsWith(key, "map_") && key != "bump" && key != "disp" && key != "decal" && key != "refl" &&
        key != "norm") {
      continue;
    }
    const size_t last = rest.find_last_of(" \t");
    files.emplace_back(rest.substr(last + 1));
  }
  return files;
}

// Rewrites `mtllib` lines so that they reach, from `output`'s folder, the files they named from
// `input`'s; names missing material files and texture images in `dropped`.
void RelinkMaterials(Mesh& mesh, const std::string& input, const std::string& output,
                     std::vector<std::string>& dropped) {
  const fs::path in_dir = fs::absolute(fs::path(input)).parent_path();
  const fs::path out_dir = fs::absolute(fs::path(output)).parent_path();
  for (ObjDirective& d : mesh.obj_directives) {
    if (!absl::StartsWith(d.line, "mtllib")) continue;
    const std::string name(absl::StripAsciiWhitespace(absl::StripPrefix(d.line, "mtllib")));
    const fs::path mtl = fs::path(name).is_absolute() ? fs::path(name) : in_dir / name;
    std::error_code error;
    if (!fs::is_regular_file(mtl, error)) {
      dropped.push_back(absl::StrCat("material library '", name, "' (not found beside the input)"));
      continue;
    }
    for (const std::string& texture : TextureFiles(mtl.string())) {
      const fs::path image = fs::path(texture).is_absolute() ? fs::path(texture) : mtl.parent_path() / texture;
      if (!fs::is_regular_file(image, error)) {
        dropped.push_back(absl::StrCat("texture image '", texture, "' of ", name, " (not found)"));
      }
    }
    const fs::path relative = fs::weakly_canonical(mtl, error).lexically_relative(fs::weakly_canonical(out_dir, error));
    const std::string target = relative.empty() ? fs::weakly_canonical(mtl, error).string() : relative.generic_string();
    d.line = absl::StrCat("mtllib ", target);
  }
}

// What `format` cannot hold of `mesh`, one phrase each.
std::vector<std::string> NotHeldBy(const Mesh& mesh, MeshFormat format) {
  std::vector<std::string> lost;
  const char* name = format == MeshFormat::kObj   ? ".obj"
                     : format == MeshFormat::kPly ? ".ply"
                     : format == MeshFormat::kOff ? ".off"
                     : format == MeshFormat::kStl ? ".stl"
                                                  : ".drc";
  const bool obj = format == MeshFormat::kObj, ply = format == MeshFormat::kPly, drc = format == MeshFormat::kDraco;
  if (!mesh.obj_directives.empty() && !obj) {
    lost.push_back(
        absl::StrCat(mesh.obj_directives.size(), " OBJ material and group lines (", name, " has no place for them)"));
  }
  if (!mesh.properties.empty() && !ply && !drc) {
    std::vector<std::string> names;
    for (const VertexProperty& p : mesh.properties) names.push_back(p.name);
    lost.push_back(
        absl::StrCat("vertex properties ", absl::StrJoin(names, ", "), " (", name, " has no place for them)"));
  }
  if (!obj && !ply && !drc) {
    if (!mesh.uvs.empty()) lost.push_back(absl::StrCat("texture coordinates (", name, " has no place for them)"));
    if (!mesh.normals.empty()) lost.push_back(absl::StrCat("normals (", name, " has no place for them)"));
    if (!mesh.colors.empty()) lost.push_back(absl::StrCat("vertex colours (", name, " has no place for them)"));
  }
  return lost;
}

// Puts back each vertex of `result` that is where the service got it (the float32 of its sent
// position: the job did not move it) at its position as sent, in double.
void KeepUnmoved(const std::vector<Vec3>& sent, std::vector<Vec3>& result) {
  const size_t n = std::min(sent.size(), result.size());
  for (size_t v = 0; v < n; ++v) {
    const Vec3& s = sent[v];
    const Vec3& r = result[v];
    if (static_cast<double>(static_cast<float>(s.x)) == r.x && static_cast<double>(static_cast<float>(s.y)) == r.y &&
        static_cast<double>(static_cast<float>(s.z)) == r.z) {
      result[v] = s;
    }
  }
}

// The phrase for positions far from the origin written in float32 by `format`.
std::string Float32Loss(const std::vector<Vec3>& positions, const char* format) {
  return absl::StrCat("coordinates in double (", format, " holds float32, which steps by ", Float32Spacing(positions),
                      " at these coordinates; .obj, .off and .ply keep them)");
}

// EncodeDraco(mesh, options) with `strength` (when not empty) as the property kStrengthAttribute,
// which replaces one of that name for the upload only: the mesh keeps its own properties.
absl::StatusOr<std::string> EncodeWithStrength(Mesh& mesh, const std::vector<float>& strength,
                                               const DracoOptions& options) {
  if (strength.empty()) return EncodeDraco(mesh, options);
  std::vector<VertexProperty> own = mesh.properties;
  std::erase_if(mesh.properties, [](const VertexProperty& p) { return p.name == kStrengthAttribute; });
  mesh.properties.push_back({kStrengthAttribute, "float", std::vector<double>(strength.begin(), strength.end())});
  absl::StatusOr<std::string> bytes = EncodeDraco(mesh, options);
  mesh.properties = std::move(own);
  return bytes;
}

// The end of an upload of a mesh read in double (`double_read`: its file held double), in its
// own coordinates, with its strength (VertexStrength) computed: faces naming a vertex that does
// not exist left out, the positions moved to the local origin, then the mesh kept for a job in
// memory or encoded (with its attributes or bare; positions quantized to `quantize` of the mean
// edge when above 0).
absl::Status FinishUpload(Upload& upload, Mesh mesh, std::vector<float> weights, bool double_read, bool with_attributes,
                          bool in_memory, double quantize = 0.0) {
  // Faces naming a vertex that does not exist cannot be sent (Draco cannot store them); the
  // server checks the rest of the mesh. Only this count is needed here: the full validation
  // builds the topology, 11% of the CLI's whole process on the dragon.
  const int32_t n = mesh.num_vertices();
  auto out_of_range = [n](const Triangle& t) { return IndexOutOfRange(t, n); };
  const auto bad_faces = std::count_if(mesh.triangles.begin(), mesh.triangles.end(), out_of_range);
  if (bad_faces > 0) {
    upload.warnings.push_back(
        absl::StrCat(bad_faces, " faces reference vertices that do not exist; they cannot be sent and are left out"));
    DropTriangles(mesh, out_of_range);  // out of step with the result's faces otherwise
  }
  upload.strength = !weights.empty();
  upload.origin = LocalOrigin(mesh.positions);
  // PLY output in double when float could not hold the input: a vertex the job leaves where it
  // is must come back as it went in.
  upload.double_positions =
      double_read || upload.origin != Vec3{} ||
      std::any_of(mesh.positions.begin(), mesh.positions.end(), [](const Vec3& p) { return RoundToFloat(p) != p; });
  if (upload.origin != Vec3{}) Translate(mesh.positions, -upload.origin);
  upload.num_vertices = mesh.num_vertices();
  if (in_memory) {
    if (absl::Status s = CheckPositionsEncodable(mesh); !s.ok()) return s;
    upload.strength_values = std::move(weights);
    upload.kept = std::move(mesh);
    return absl::OkStatus();
  }
  DracoOptions options;
  if (quantize > 0.0) {
    upload.quantization = ChooseUploadQuantization(mesh, quantize);
    options.quantization_bits = upload.quantization.bits;
  }
  absl::StatusOr<std::string> bytes;
  if (with_attributes) {
    bytes = EncodeWithStrength(mesh, weights, options);
  } else {  // the positions and faces lent to a mesh of their own, then given back
    Mesh bare;
    bare.positions = std::move(mesh.positions);
    bare.triangles = std::move(mesh.triangles);
    bytes = EncodeWithStrength(bare, weights, options);
    mesh.positions = std::move(bare.positions);
    mesh.triangles = std::move(bare.triangles);
  }
  if (!bytes.ok()) return bytes.status();
  upload.draco = std::move(*bytes);
  upload.kept = std::move(mesh);
  return absl::OkStatus();
}

absl::Status AboutResult(const absl::Status& s) {
  return absl::Status(s.code(), absl::StrCat("the result: ", s.message()));
}

// The end of WriteResult for every output but .drc and glTF: `mesh` (the result's positions with
// the input's attributes, or a Draco input's result as decoded) moved back by the origin, the
// ridge `labels` (one per point, when `ridges`) as colours, written in `format`.
absl::Status WriteMesh(const Upload& upload, Mesh mesh, const std::vector<uint8_t>& labels, MeshFormat format,
                       const std::string& output, bool ridges, std::vector<std::string>& lost) {
  if (upload.origin != Vec3{}) {
    Translate(mesh.positions, upload.origin);
    if (format == MeshFormat::kStl) lost.push_back(Float32Loss(mesh.positions, ".stl"));
  }
  if (ridges) {
    std::vector<uint8_t> bytes = labels;
    bytes.resize(mesh.positions.size());
    mesh.colors = FeatureColors(bytes);
    // Shown as the colours; the curvatures are the service's, not the input's.
    std::erase_if(mesh.properties, [](const VertexProperty& p) {
      return p.name == kFeatureLabelAttribute || p.name == kKmaxAttribute || p.name == kKminAttribute;
    });
  }
  for (std::string& s : NotHeldBy(mesh, format)) lost.push_back(std::move(s));
  if (format == MeshFormat::kPly && !mesh.normals.empty() && !PerVertexValues(mesh, mesh.normals).has_value()) {
    lost.push_back("hard edges (.ply holds one normal per vertex: the smooth one is written)");
    mesh.normals = FreshNormals(mesh, {});
  }
  if (format == MeshFormat::kObj && !upload.draco_input) RelinkMaterials(mesh, upload.input, output, lost);
  WriteOptions options;
  options.ply_double = upload.double_positions;
  return meshsmooth::WriteMesh(output, mesh, options);
}

// The ridge labels of the service's result, one per point (`ridges`); empty without.
absl::StatusOr<std::vector<uint8_t>> ResultLabels(const std::string& result, bool ridges) {
  if (!ridges) return std::vector<uint8_t>();
  absl::StatusOr<std::vector<float>> values = DecodeDracoAttribute(result, kFeatureLabelAttribute);
  if (!values.ok()) return AboutResult(values.status());
  return std::vector<uint8_t>(values->begin(), values->end());
}

// The result of a mesh file's upload (one point per vertex, relative to the origin) with the
// input's triangles and attributes around it: each vertex the job did not move at its position
// as sent, in double; normals recomputed from the smoothed positions. Moves them out of
// `upload.kept`.
Mesh AroundPoints(Upload& upload, std::vector<Vec3> points) {
  Mesh mesh;
  mesh.positions = std::move(points);
  KeepUnmoved(upload.kept.positions, mesh.positions);
  mesh.triangles = std::move(upload.kept.triangles);
  mesh.colors = std::move(upload.kept.colors);
  mesh.uvs = std::move(upload.kept.uvs);
  mesh.properties = std::move(upload.kept.properties);
  mesh.obj_directives = std::move(upload.kept.obj_directives);
  if (!upload.kept.normals.empty()) mesh.normals = FreshNormals(mesh, upload.kept.normals);
  return mesh;
}

}  // namespace

absl::Status CheckOutputPath(const std::string& output) {
  if (!IsGltfPath(output)) {
    if (absl::StatusOr<MeshFormat> format = FormatFromPath(output); !format.ok()) return format.status();
  }
  std::error_code error;
  if (fs::is_directory(output, error)) {
    return absl::InvalidArgumentError(
        absl::StrCat("-o ", output, ": a folder, not a file (for a batch's results, end it with '/')"));
  }
  fs::path folder = fs::path(output).parent_path();
  if (folder.empty()) folder = ".";
  if (!fs::is_directory(folder, error)) {
    return absl::InvalidArgumentError(absl::StrCat("-o ", output, ": no folder ", folder.string()));
  }
  if (access(folder.c_str(), W_OK) != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("-o ", output, ": the folder ", folder.string(), " is not writable"));
  }
  return absl::OkStatus();
}

bool IsGltfPath(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".gltf" || ext == ".glb";
}

absl::StatusOr<Upload> PrepareUpload(const std::string& input, bool with_attributes, bool gltf_draco,
                                     const StrengthOptions& strength, bool in_memory, double quantize_upload) {
  Upload upload;
  upload.input = input;
  const absl::StatusOr<MeshFormat> format = FormatFromPath(input);
  if (quantize_upload > 0.0 && (IsGltfPath(input) || (format.ok() && *format == MeshFormat::kDraco))) {
    return absl::InvalidArgumentError(
        "--quantize-upload quantizes an OBJ, PLY, OFF or STL input (or builtin:NAME); a .drc or glTF input is sent "
        "as it is");
  }
  if (strength.any() && (IsGltfPath(input) || (format.ok() && *format == MeshFormat::kDraco))) {
    return absl::InvalidArgumentError(
        "--weight, --fixed and --region read OBJ, PLY, OFF or STL input (or builtin:NAME), not a .drc or glTF file");
  }
  if (IsGltfPath(input)) {
    // Before any thread starts (ReadInChildFirst forks).
    absl::StatusOr<GltfScene> scene = GltfScene::ReadInChildFirst(input, gltf_draco);
    if (!scene.ok()) return scene.status();
    upload.gltf = std::make_shared<GltfScene>(std::move(*scene));
    upload.dropped = upload.gltf->stale();
    absl::StatusOr<std::string> bytes = EncodeDraco(upload.gltf->surface());
    if (!bytes.ok()) return bytes.status();
    upload.draco = std::move(*bytes);
    upload.num_vertices = upload.gltf->surface().num_vertices();
    return upload;
  }
  if (format.ok() && *format == MeshFormat::kDraco) {
    absl::StatusOr<std::string> bytes = ReadFileBytes(input);
    if (!bytes.ok()) return bytes.status();
    upload.draco = std::move(*bytes);
    upload.draco_input = true;
    return upload;
  }
  ReadInfo info;
  absl::StatusOr<Mesh> mesh = LoadInput(input, &info);
  if (!mesh.ok()) return mesh.status();
  upload.dropped = std::move(info.dropped);
  if (info.polygons_fanned > 0) upload.dropped.push_back(absl::StrCat(info.polygons_fanned, " polygons triangulated"));
  // In the file's own coordinates, before the shift to the local origin.
  absl::StatusOr<std::vector<float>> weights = VertexStrength(*mesh, strength);
  if (!weights.ok()) return weights.status();
  if (absl::Status s = FinishUpload(upload, *std::move(mesh), *std::move(weights), info.double_positions,
                                    with_attributes, in_memory, quantize_upload);
      !s.ok()) {
    return s;
  }
  return upload;
}

absl::StatusOr<Upload> UploadMesh(Mesh mesh, std::vector<float> strength, bool in_memory) {
  if (!strength.empty() && strength.size() != mesh.positions.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("strength: ", strength.size(), " values for ", mesh.positions.size(), " vertices"));
  }
  Upload upload;
  upload.input = "a mesh in memory";
  if (absl::Status s = FinishUpload(upload, std::move(mesh), std::move(strength), false, false, in_memory); !s.ok()) {
    return s;
  }
  return upload;
}

absl::Status WriteResult(Upload& upload, const std::string& result, const std::string& output, bool ridges,
                         std::vector<std::string>* dropped, bool gltf_draco, const DracoOptions& draco) {
  std::vector<std::string> ignored;
  std::vector<std::string>& lost = dropped != nullptr ? *dropped : ignored;
  if (upload.gltf != nullptr && !IsGltfPath(output)) {
    return absl::InvalidArgumentError("a glTF scene is written as a scene: give -o FILE.glb or FILE.gltf");
  }
  if (upload.gltf == nullptr && IsGltfPath(output)) {
    // One node, translated by the origin, places the mesh (its float32 positions near zero).
    if (!upload.kept.obj_directives.empty()) {
      lost.push_back(absl::StrCat(upload.kept.obj_directives.size(),
                                  " OBJ material and group lines (glTF output has no place for them)"));
    }
    if (ridges) lost.push_back("the ridge labels (a glTF scene has no place for them)");
    return WriteMeshAsGltf(result, upload.origin, output, gltf_draco, &lost);
  }
  if (upload.gltf != nullptr) {
    absl::StatusOr<Mesh> decoded = DecodeDraco(result, nullptr, false);
    if (!decoded.ok() || decoded->num_vertices() != upload.num_vertices) {
      return absl::DataLossError("the result: not one point per point of the scene's primitives");
    }
    if (ridges) lost.push_back("the ridge labels (a glTF scene has no place for them)");
    return upload.gltf->Write(decoded->positions, output, gltf_draco);
  }
  absl::StatusOr<MeshFormat> format = FormatFromPath(output);
  if (!format.ok()) return format.status();
  if (*format == MeshFormat::kDraco) {
    for (std::string& s : NotHeldBy(upload.kept, *format)) lost.push_back(std::move(s));
    if (upload.origin == Vec3{}) return WriteFileBytes(output, result);
    // Moved back by the origin the positions were sent relative to, every attribute along.
    absl::StatusOr<Mesh> decoded = DecodeDraco(result);
    if (!decoded.ok())
      return absl::Status(decoded.status().code(), absl::StrCat("the result: ", decoded.status().message()));
    Translate(decoded->positions, upload.origin);
    lost.push_back(Float32Loss(decoded->positions, ".drc"));
    absl::StatusOr<std::string> bytes = EncodeDraco(*decoded, draco);
    if (!bytes.ok()) return bytes.status();
    return WriteFileBytes(output, *bytes);
  }
  if (!upload.draco_input) {
    absl::StatusOr<ResultPoints> points = DecodeResultPoints(upload, result, ridges);
    if (!points.ok()) return points.status();
    return WriteResultPoints(upload, std::move(points->points), points->labels, output, ridges, &lost);
  }
  // Only a Draco input's attributes come from the result; the others' are the input's own.
  absl::StatusOr<Mesh> decoded = DecodeDraco(result, &lost, true);
  if (!decoded.ok()) return AboutResult(decoded.status());
  absl::StatusOr<std::vector<uint8_t>> labels = ResultLabels(result, ridges);
  if (!labels.ok()) return labels.status();
  return WriteMesh(upload, *std::move(decoded), *labels, *format, output, ridges, lost);
}

absl::StatusOr<ResultPoints> DecodeResultPoints(const Upload& upload, const std::string& result, bool ridges) {
  absl::StatusOr<Mesh> decoded = DecodeDraco(result, nullptr, false);
  if (!decoded.ok()) return AboutResult(decoded.status());
  // Vertex i is point i of the result (SplitAtSeams puts the seams' points after them).
  if (decoded->num_vertices() < upload.num_vertices) {
    return AboutResult(absl::DataLossError(
        absl::StrCat("it has ", decoded->num_vertices(), " points for ", upload.num_vertices, " vertices")));
  }
  ResultPoints out;
  absl::StatusOr<std::vector<uint8_t>> labels = ResultLabels(result, ridges);
  if (!labels.ok()) return labels.status();
  out.labels = *std::move(labels);
  out.points = std::move(decoded->positions);
  out.points.resize(upload.num_vertices);
  return out;
}

absl::Status WriteResultPoints(Upload& upload, std::vector<Vec3> points, const std::vector<uint8_t>& labels,
                               const std::string& output, bool ridges, std::vector<std::string>* dropped) {
  std::vector<std::string> ignored;
  std::vector<std::string>& lost = dropped != nullptr ? *dropped : ignored;
  absl::StatusOr<MeshFormat> format = FormatFromPath(output);
  if (!format.ok()) return format.status();
  if (*format == MeshFormat::kDraco || upload.draco_input || upload.gltf != nullptr ||
      static_cast<int64_t>(points.size()) != upload.num_vertices) {
    return absl::InvalidArgumentError("the result of a job run in memory is written from a mesh file's upload only");
  }
  return WriteMesh(upload, AroundPoints(upload, std::move(points)), labels, *format, output, ridges, lost);
}

absl::StatusOr<Mesh> ResultMesh(Upload& upload, std::vector<Vec3> points) {
  if (upload.draco_input || upload.gltf != nullptr || static_cast<int64_t>(points.size()) != upload.num_vertices) {
    return absl::InvalidArgumentError("a result mesh is made from a mesh's upload and one point per vertex");
  }
  Mesh mesh = AroundPoints(upload, std::move(points));
  if (upload.origin != Vec3{}) Translate(mesh.positions, upload.origin);
  return mesh;
}

}  // namespace meshsmooth::client
