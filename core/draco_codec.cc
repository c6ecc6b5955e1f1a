#include "core/draco_codec.h"

#include <exception>
#include <memory>

#include "absl/strings/str_cat.h"
#include "draco/compression/decode.h"
#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"

namespace meshsmooth {

absl::StatusOr<std::string> EncodeDraco(const Mesh& mesh, const DracoOptions& options) {
  if (options.quantization_bits < 0 || options.quantization_bits > 30) {
    return absl::InvalidArgumentError(
        absl::StrCat("quantization bits must be 0 (lossless) or 1..30, got ", options.quantization_bits));
  }
  if (options.speed < 0 || options.speed > 10) {
    return absl::InvalidArgumentError(absl::StrCat("Draco speed must be 0..10, got ", options.speed));
  }
  const int32_t n = mesh.num_vertices();
  if (n == 0 || mesh.triangles.empty()) {
    return absl::InvalidArgumentError("cannot encode an empty mesh (no vertices or no faces)");
  }

  draco::Mesh dm;
  dm.set_num_points(n);
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
  const int att_id = dm.AddAttribute(ga, /*identity_mapping=*/true, n);
  draco::PointAttribute* positions = dm.attribute(att_id);
  for (int32_t i = 0; i < n; ++i) {
    const Vec3& p = mesh.positions[i];
    const float v[3] = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
    positions->SetAttributeValue(draco::AttributeValueIndex(i), v);
  }
  for (const Triangle& t : mesh.triangles) {
    // Out-of-range faces cannot be stored (the validation report counts them).
    if (t[0] < 0 || t[0] >= n || t[1] < 0 || t[1] >= n || t[2] < 0 || t[2] >= n) continue;
    dm.AddFace({draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
  }

  draco::Encoder encoder;
  encoder.SetSpeedOptions(options.speed, options.speed);
  encoder.SetEncodingMethod(options.method == DracoMethod::kSequential ? draco::MESH_SEQUENTIAL_ENCODING
                                                                       : draco::MESH_EDGEBREAKER_ENCODING);
  if (options.quantization_bits > 0) {
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, options.quantization_bits);
  }
  draco::EncoderBuffer out;
  const draco::Status status = encoder.EncodeMeshToBuffer(dm, &out);
  if (!status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("Draco encoding failed: ", status.error_msg_string()));
  }
  return std::string(out.data(), out.size());
}

absl::StatusOr<Mesh> DecodeDraco(std::string_view bytes) {
  if (bytes.empty()) return absl::InvalidArgumentError("empty Draco data");
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
  if (!type.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("not a Draco bitstream (corrupt header): ", type.status().error_msg_string()));
  }
  if (type.value() == draco::POINT_CLOUD) {
    return absl::InvalidArgumentError("the Draco data holds a point cloud, not a triangle mesh");
  }
  if (type.value() != draco::TRIANGULAR_MESH) {
    return absl::InvalidArgumentError("the Draco data holds no triangle mesh (invalid geometry type)");
  }
  std::unique_ptr<draco::Mesh> dm;
  try {
    buffer.Init(bytes.data(), bytes.size());
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
    if (!decoded.ok()) {
      return absl::InvalidArgumentError(
          // Draco itself cannot decode a mesh without faces, so "empty" is named here too.
          absl::StrCat("corrupt or empty Draco mesh: ", decoded.status().error_msg_string()));
    }
    dm = std::move(decoded).value();
  } catch (const std::exception& e) {  // e.g. bad_alloc for absurd counts in corrupt data
    return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: ", e.what()));
  }
  if (dm == nullptr || dm->num_points() == 0 || dm->num_faces() == 0) {
    return absl::InvalidArgumentError("the Draco mesh is empty (no points or no faces)");
  }
  const draco::PointAttribute* pos = dm->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (pos == nullptr || pos->num_components() < 3 || pos->size() == 0) {
    return absl::InvalidArgumentError("the Draco mesh has no 3-D position attribute");
  }
  Mesh mesh;
  const uint32_t n = dm->num_points();
  mesh.positions.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    const draco::AttributeValueIndex avi = pos->mapped_index(draco::PointIndex(i));
    double xyz[3];
    if (avi.value() >= pos->size() || !pos->ConvertValue<double>(avi, 3, xyz)) {
      return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: no position for point ", i));
    }
    mesh.positions[i] = {xyz[0], xyz[1], xyz[2]};
  }
  mesh.triangles.resize(dm->num_faces());
  for (uint32_t f = 0; f < dm->num_faces(); ++f) {
    const draco::Mesh::Face& face = dm->face(draco::FaceIndex(f));
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = face[c].value();
      mesh.triangles[f][c] = v < n ? static_cast<int32_t>(v) : -1;
    }
  }
  return mesh;
}

}  // namespace meshsmooth
