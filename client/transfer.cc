#include "client/transfer.h"

#include "absl/strings/str_cat.h"
#include "client/inputs.h"
#include "core/features/ridges.h"
#include "core/io/coordinates.h"
#include "core/io/draco_codec.h"
#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/topology.h"

namespace meshsmooth::client {

absl::StatusOr<Upload> PrepareUpload(const std::string& input) {
  Upload upload;
  const absl::StatusOr<MeshFormat> format = FormatFromPath(input);
  if (format.ok() && *format == MeshFormat::kDraco) {
    absl::StatusOr<std::string> bytes = ReadFileBytes(input);
    if (!bytes.ok()) return bytes.status();
    upload.draco = std::move(*bytes);
    return upload;
  }
  ReadInfo info;
  absl::StatusOr<Mesh> mesh = LoadInput(input, &info);
  if (!mesh.ok()) return mesh.status();
  const ValidationReport r = Validate(*mesh);
  if (r.faces_out_of_range > 0) {
    upload.warnings.push_back(absl::StrCat(r.faces_out_of_range,
                                           " faces reference vertices that do not exist; they cannot be sent "
                                           "and are left out"));
  }
  upload.origin = LocalOrigin(mesh->positions);
  upload.double_positions = info.double_positions || upload.origin != Vec3{};
  if (upload.origin != Vec3{}) Translate(mesh->positions, -upload.origin);
  absl::StatusOr<std::string> bytes = EncodeDraco(*mesh);
  if (!bytes.ok()) return bytes.status();
  upload.draco = std::move(*bytes);
  upload.colors = std::move(mesh->colors);
  return upload;
}

absl::Status WriteResult(const Upload& upload, const std::string& result, const std::string& output, bool ridges) {
  absl::StatusOr<MeshFormat> format = FormatFromPath(output);
  if (!format.ok()) return format.status();
  if (*format == MeshFormat::kDraco) return WriteFileBytes(output, result);
  auto about_result = [](const absl::Status& s) {
    return absl::Status(s.code(), absl::StrCat("the result: ", s.message()));
  };
  absl::StatusOr<Mesh> mesh = DecodeDraco(result);
  if (!mesh.ok()) return about_result(mesh.status());
  if (upload.origin != Vec3{}) Translate(mesh->positions, upload.origin);
  if (ridges) {
    absl::StatusOr<std::vector<float>> labels = DecodeDracoAttribute(result, kFeatureLabelAttribute);
    if (!labels.ok()) return about_result(labels.status());
    mesh->colors = FeatureColors(std::vector<uint8_t>(labels->begin(), labels->end()));
  } else if (upload.colors.size() == mesh->positions.size()) {
    mesh->colors = upload.colors;
  }
  WriteOptions options;
  options.ply_double = upload.double_positions;
  return WriteMesh(output, *mesh, options);
}

}  // namespace meshsmooth::client
