#include "core/io/draco_checks.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "draco/compression/config/compression_shared.h"
#include "draco/compression/point_cloud/point_cloud_decoder.h"
#include "draco/core/varint_decoding.h"
#include "draco/metadata/geometry_metadata.h"
#include "draco/metadata/metadata_decoder.h"

namespace meshsmooth {
namespace {

// Points a decoded mesh may have: vertex and point indices are int32 here (and the weld packs
// a point index into 31 bits).
constexpr uint32_t kMaxPoints = std::numeric_limits<int32_t>::max();
// Attributes a decoded mesh may have. Real files carry a handful; every check and copy of a
// point's attributes, and the search for an attribute by name, is linear in their number.
constexpr int32_t kMaxAttributes = 256;
// Edgebreaker counts a file of B bytes may declare: kDeclaredCountFloor + kDeclaredCountsPerByte
// * B faces, and as many vertices. The densest real encoding measured, a flat 700 x 700 grid at
// 4 quantization bits and compression level 10 (draco_encoder), holds 67 faces a byte; the
// bound leaves 15 times that, and small files room for a million.
constexpr int64_t kDeclaredCountFloor = int64_t{1} << 20;
constexpr int64_t kDeclaredCountsPerByte = 1024;

}  // namespace

absl::Status CheckCoordinates(const Vec3& p, const char* what, int64_t index) {
  for (double c : {p.x, p.y, p.z}) {
    if (!(std::abs(c) <= kMaxCoordinate)) {
      return absl::InvalidArgumentError(absl::StrCat(what, " ", index, " has a coordinate of ", c,
                                                     ": coordinates must be finite and at most 2^100 (", kMaxCoordinate,
                                                     ") in magnitude"));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckSequentialPoints(int64_t points, int64_t faces) {
  if (points <= 3 * faces) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat("Draco's sequential encoding cannot hold more than 3 points per face: ", points, " points, ", faces,
                   " faces with every index in range (remove the unreferenced vertices)"));
}

absl::Status CheckDracoOptions(const DracoOptions& options) {
  if (options.quantization_bits < 0 || options.quantization_bits > kMaxQuantizationBits) {
    return absl::InvalidArgumentError(absl::StrCat("quantization bits must be 0 (lossless) or 1..",
                                                   kMaxQuantizationBits, ", got ", options.quantization_bits));
  }
  if (options.speed < 0 || options.speed > 10) {
    return absl::InvalidArgumentError(absl::StrCat("Draco speed must be 0..10, got ", options.speed));
  }
  return absl::OkStatus();
}

namespace {

// The counts at the head of Draco mesh bytes, as ReadDeclaredCounts says, and for Edgebreaker
// the count of new vertices (before 2.2) and split symbols that add vertices to the declared.
struct HeadCounts {
  bool edgebreaker = false;
  uint32_t faces = 0, points = 0, new_vertices = 0, split_symbols = 0;
};

std::optional<HeadCounts> ReadHeadCounts(std::string_view bytes) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::DracoHeader header;
  if (!draco::PointCloudDecoder::DecodeHeader(&buffer, &header).ok()) return std::nullopt;
  if (header.encoder_type != draco::TRIANGULAR_MESH) return std::nullopt;
  const bool edgebreaker = header.encoder_method == draco::MESH_EDGEBREAKER_ENCODING;
  if (!edgebreaker && header.encoder_method != draco::MESH_SEQUENTIAL_ENCODING) return std::nullopt;
  // The layout PointCloudDecoder::Decode reads: metadata (from 1.3, when flagged), then the
  // connectivity's counts, raw uint32 before 2.0 (sequential: before 2.2) and varints after.
  const uint16_t version = DRACO_BITSTREAM_VERSION(header.version_major, header.version_minor);
  buffer.set_bitstream_version(version);
  if (version >= DRACO_BITSTREAM_VERSION(1, 3) && (header.flags & METADATA_FLAG_MASK)) {
    draco::GeometryMetadata metadata;
    if (!draco::MetadataDecoder().DecodeGeometryMetadata(&buffer, &metadata)) return std::nullopt;
  }
  HeadCounts out;
  out.edgebreaker = edgebreaker;
  if (!edgebreaker) {  // MeshSequentialDecoder::DecodeConnectivity: the faces, then the points
    const bool raw = version < DRACO_BITSTREAM_VERSION(2, 2);
    auto count = [&](uint32_t& v) { return raw ? buffer.Decode(&v) : draco::DecodeVarint(&v, &buffer); };
    if (!count(out.faces) || !count(out.points)) return std::nullopt;
    return out;
  }
  // MeshEdgebreakerDecoderImpl::DecodeConnectivity: the traversal's type, then the counts;
  // before 2.2 a count of new vertices comes first.
  uint8_t traversal = 0;
  if (!buffer.Decode(&traversal)) return std::nullopt;
  auto count = [&](uint32_t& v) {
    return version < DRACO_BITSTREAM_VERSION(2, 0) ? buffer.Decode(&v) : draco::DecodeVarint(&v, &buffer);
  };
  uint32_t symbols = 0;
  uint8_t attribute_data = 0;
  if (version < DRACO_BITSTREAM_VERSION(2, 2) && !count(out.new_vertices)) return std::nullopt;
  if (!count(out.points) || !count(out.faces) || !buffer.Decode(&attribute_data) || !count(symbols) ||
      !count(out.split_symbols)) {
    return std::nullopt;
  }
  return out;
}

}  // namespace

std::optional<DracoCounts> DracoDeclaredCounts(std::string_view head) {
  const std::optional<HeadCounts> c = ReadHeadCounts(head);
  if (!c.has_value()) return std::nullopt;
  // Draco refuses more split symbols than symbols; counted anyway, the bound stays an upper one.
  return DracoCounts{c->faces, int64_t{c->points} + c->new_vertices + c->split_symbols};
}

absl::StatusOr<std::optional<DeclaredSizes>> CheckDeclaredEdgebreakerSizes(std::string_view bytes,
                                                                           int64_t max_vertices) {
  const std::optional<HeadCounts> c = ReadHeadCounts(bytes);
  if (!c.has_value() || !c->edgebreaker) return std::nullopt;
  const int64_t faces = c->faces;
  const int64_t declared_vertices = int64_t{c->points} + c->new_vertices + c->split_symbols;
  if (faces > 4 * max_vertices || declared_vertices > 2 * max_vertices) {
    return absl::ResourceExhaustedError(absl::StrCat("the Draco data declares ", faces, " faces and ",
                                                     declared_vertices, " vertices (Edgebreaker); with a limit of ",
                                                     max_vertices, " vertices at most ", 4 * max_vertices,
                                                     " faces and ", 2 * max_vertices, " vertices are decoded"));
  }
  // Within the limit, counts no real encoding can back: files read from disk have no limit
  // but int32 indices, and 436 bytes declaring 657 million faces make Draco ask for 7.9 GB.
  const int64_t plausible = kDeclaredCountFloor + kDeclaredCountsPerByte * static_cast<int64_t>(bytes.size());
  if (faces > plausible || declared_vertices > plausible) {
    return absl::InvalidArgumentError(
        absl::StrCat("corrupt Draco mesh: ", bytes.size(), " bytes declare ", faces, " faces and ", declared_vertices,
                     " vertices (Edgebreaker); at most ", plausible, " of each fit in that many bytes"));
  }
  return DeclaredSizes{faces, declared_vertices};
}

absl::Status CheckQuantizedExtent(const draco::PointAttribute& positions) {
  float lo[3], hi[3];
  for (int c = 0; c < 3; ++c) lo[c] = std::numeric_limits<float>::infinity(), hi[c] = -lo[c];
  for (uint32_t i = 0; i < positions.size(); ++i) {
    float v[3];
    positions.GetValue(draco::AttributeValueIndex(i), v);
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], v[c]), hi[c] = std::max(hi[c], v[c]);
  }
  double extent = 0.0;
  for (int c = 0; c < 3; ++c) extent = std::max(extent, static_cast<double>(hi[c]) - lo[c]);
  if (extent > 0.0 && extent < kMinQuantizedExtent) {
    return absl::InvalidArgumentError(absl::StrCat("the mesh is too small to quantize: it spans ", extent,
                                                   ", less than 2^-100 (", kMinQuantizedExtent,
                                                   "); ask for lossless output (0 quantization bits)"));
  }
  return absl::OkStatus();
}

absl::Status CheckNumericValues(const draco::PointAttribute& a, std::string_view what) {
  const draco::DataType t = a.data_type();
  if (t >= draco::DT_INT8 && t <= draco::DT_FLOAT64) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("the Draco mesh's ", absl::string_view(what.data(), what.size()),
                                                 t == draco::DT_BOOL ? " holds booleans" : " has no data type",
                                                 "; meshsmooth reads integers or floating-point numbers"));
}

std::vector<uint8_t> PointsEdgebreakerKeeps(const draco::Mesh& dm) {
  std::vector<uint8_t> used(dm.num_points(), 0);
  for (uint32_t f = 0; f < dm.num_faces(); ++f) {
    const draco::Mesh::Face& face = dm.face(draco::FaceIndex(f));
    if (face[0] == face[1] || face[1] == face[2] || face[0] == face[2]) continue;
    for (int c = 0; c < 3; ++c) used[face[c].value()] = 1;
  }
  return used;
}

absl::Status EdgebreakerDropsError(int64_t dropped) {
  return absl::InvalidArgumentError(absl::StrCat(
      "Edgebreaker would drop ", dropped, dropped == 1 ? " vertex" : " vertices",
      " that no face with three distinct vertices uses (isolated, or only in faces with a repeated index); ask "
      "for sequential output"));
}

absl::Status CheckDracoLayout(const draco::Mesh& dm) {
  const uint32_t n = dm.num_points();
  if (n > kMaxPoints) {
    return absl::InvalidArgumentError(
        absl::StrCat("the Draco mesh has ", n, " points; at most ", kMaxPoints, " can be read"));
  }
  if (dm.num_attributes() > kMaxAttributes) {
    return absl::InvalidArgumentError(absl::StrCat("the Draco mesh has ", dm.num_attributes(), " attributes; at most ",
                                                   kMaxAttributes, " can be read"));
  }
  int positions = 0;
  for (int32_t i = 0; i < dm.num_attributes(); ++i) {
    const draco::PointAttribute* a = dm.attribute(i);
    if (a == nullptr)
      return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: attribute ", i, " is missing"));
    const std::string name = absl::StrCat("attribute ", i, " (", a->TypeToString(a->attribute_type()), ")");
    positions += a->attribute_type() == draco::GeometryAttribute::POSITION;
    const int64_t value_bytes = int64_t{draco::DataTypeLength(a->data_type())} * a->num_components();
    const int64_t size = static_cast<int64_t>(a->size());
    const int64_t needed = size == 0 ? 0 : a->byte_offset() + a->byte_stride() * (size - 1) + value_bytes;
    if (value_bytes <= 0 || a->byte_stride() < value_bytes || a->byte_offset() < 0 || a->buffer() == nullptr ||
        needed > static_cast<int64_t>(a->buffer()->data_size())) {
      return absl::InvalidArgumentError(
          absl::StrCat("corrupt Draco mesh: the values of ", name, " do not fit its buffer"));
    }
    if (a->is_mapping_identity()) {
      if (a->size() < n) {
        return absl::InvalidArgumentError(
            absl::StrCat("corrupt Draco mesh: ", name, " has no value for point ", a->size()));
      }
      continue;
    }
    for (uint32_t p = 0; p < n; ++p) {
      if (a->mapped_index(draco::PointIndex(p)).value() >= a->size()) {
        return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: ", name, " has no value for point ", p));
      }
    }
  }
  if (positions > 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("the Draco mesh has ", positions, " POSITION attributes; meshsmooth needs exactly one"));
  }
  const draco::PointAttribute* pos = dm.GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (pos == nullptr || pos->num_components() < 3 || pos->size() == 0) {
    return absl::InvalidArgumentError("the Draco mesh has no 3-D position attribute");
  }
  if (absl::Status s = CheckNumericValues(*pos, "POSITION attribute"); !s.ok()) return s;
  for (uint32_t f = 0; f < dm.num_faces(); ++f) {
    const draco::Mesh::Face& face = dm.face(draco::FaceIndex(f));
    for (int c = 0; c < 3; ++c) {
      if (face[c].value() >= n) {
        return absl::InvalidArgumentError(absl::StrCat("corrupt Draco mesh: face ", f, " refers to point ",
                                                       face[c].value(), ", but the mesh has ", n, " points"));
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace meshsmooth
