#include "core/io/mesh_io.h"

#include <algorithm>
#include <cctype>

#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"
#include "core/io/formats.h"

namespace meshsmooth {

absl::StatusOr<MeshFormat> FormatFromPath(std::string_view path) {
  const size_t dot = path.rfind('.');
  std::string ext(dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == "obj") return MeshFormat::kObj;
  if (ext == "ply") return MeshFormat::kPly;
  if (ext == "off") return MeshFormat::kOff;
  if (ext == "stl") return MeshFormat::kStl;
  if (ext == "drc") return MeshFormat::kDraco;
  return absl::InvalidArgumentError(
      absl::StrCat("'", io::Sv(path), "': unknown mesh format (use .obj, .ply, .off, .stl or .drc)"));
}

absl::StatusOr<Mesh> ParseMesh(std::string_view data, MeshFormat format, ReadInfo* info) {
  ReadInfo local;
  ReadInfo& i = info != nullptr ? *info : local;
  i = ReadInfo{};
  switch (format) {
    case MeshFormat::kObj:
      return io::ParseObj(data, i);
    case MeshFormat::kPly:
      return io::ParsePly(data, i);
    case MeshFormat::kOff:
      return io::ParseOff(data, i);
    case MeshFormat::kStl:
      return io::ParseStl(data, i);
    case MeshFormat::kDraco:
      return DecodeDraco(data);
  }
  return absl::InvalidArgumentError("unknown mesh format");
}

absl::StatusOr<Mesh> ReadMesh(const std::string& path, ReadInfo* info) {
  absl::StatusOr<MeshFormat> format = FormatFromPath(path);
  if (!format.ok()) return format.status();
  absl::StatusOr<std::string> bytes = ReadFileBytes(path);
  if (!bytes.ok()) return bytes.status();
  absl::StatusOr<Mesh> mesh = ParseMesh(*bytes, *format, info);
  if (!mesh.ok()) {
    return absl::Status(mesh.status().code(), absl::StrCat(path, ": ", mesh.status().message()));
  }
  return mesh;
}

absl::StatusOr<std::string> SerializeMesh(const Mesh& mesh, MeshFormat format, const WriteOptions& options) {
  switch (format) {
    case MeshFormat::kObj:
      return io::WriteObj(mesh);
    case MeshFormat::kPly:
      return io::WritePly(mesh, options.ply_binary, options.ply_double);
    case MeshFormat::kOff:
      return io::WriteOff(mesh);
    case MeshFormat::kStl:
      return io::WriteStl(mesh);
    case MeshFormat::kDraco:
      return EncodeDraco(mesh, options.draco);
  }
  return absl::InvalidArgumentError("unknown mesh format");
}

absl::Status WriteMesh(const std::string& path, const Mesh& mesh, const WriteOptions& options) {
  absl::StatusOr<MeshFormat> format = FormatFromPath(path);
  if (!format.ok()) return format.status();
  absl::StatusOr<std::string> bytes = SerializeMesh(mesh, *format, options);
  if (!bytes.ok()) return bytes.status();
  return WriteFileBytes(path, *bytes);
}

}  // namespace meshsmooth
