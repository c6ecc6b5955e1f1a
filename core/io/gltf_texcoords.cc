#include "core/io/gltf_texcoords.h"

#include <cstring>
#include <filesystem>
#include <functional>
#include <string_view>
#include <vector>

#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"
#include "nlohmann/json.hpp"

namespace meshsmooth {
namespace {

using Json = nlohmann::json;

constexpr uint32_t kAmbiguous = 0xffffffffu;
constexpr int kFloat = 5126;  // glTF's componentType for float32

// A glTF file's JSON and its buffers, each with where it is written back.
struct GltfFile {
  std::string path;
  Json json;
  bool glb = false;
  std::string glb_bytes;  // a .glb: the whole file (its BIN chunk is buffer 0)
  size_t bin_offset = 0, bin_size = 0;
  std::vector<std::string> buffers;  // a .gltf: each buffer's bytes
  std::vector<std::string> files;    // and its file ("" for a data URI)
};

absl::Status Bad(const std::string& path, const char* what) {
  return absl::InvalidArgumentError(absl::StrCat(path, ": ", what));
}

uint32_t Le32(std::string_view b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

// An unsigned integer member of `j`, or `fallback` when it is absent; -1 when it is not one.
int64_t Uint(const Json& j, const char* key, int64_t fallback) {
  if (!j.is_object() || !j.contains(key)) return fallback;
  const Json& v = j[key];
  return v.is_number_unsigned() ? static_cast<int64_t>(v.get<uint64_t>()) : -1;
}

absl::StatusOr<GltfFile> Load(const std::string& path) {
  GltfFile f;
  f.path = path;
  absl::StatusOr<std::string> bytes = ReadFileBytes(path);
  if (!bytes.ok()) return bytes.status();
  std::string_view json_text = *bytes;
  if (bytes->size() >= 12 && bytes->compare(0, 4, "glTF") == 0) {
    f.glb = true;
    f.glb_bytes = std::move(*bytes);
    const std::string_view b = f.glb_bytes;
    size_t at = 12;
    json_text = {};
    while (at + 8 <= b.size()) {
      const uint64_t length = Le32(b, at), type = Le32(b, at + 4);
      if (length > b.size() - at - 8) return Bad(path, "a GLB chunk past the end of the file");
      if (type == 0x4E4F534Au && json_text.empty()) json_text = b.substr(at + 8, length);  // "JSON"
      if (type == 0x004E4942u && f.bin_size == 0) {                                        // "BIN\0"
        f.bin_offset = at + 8;
        f.bin_size = length;
      }
      at += 8 + length;
    }
  }
  f.json = Json::parse(json_text.begin(), json_text.end(), nullptr, false);
  if (f.json.is_discarded() || !f.json.is_object()) return Bad(path, "glTF JSON that does not parse");
  if (f.glb) return f;
  const Json& buffers = f.json.contains("buffers") ? f.json["buffers"] : Json::array();
  if (!buffers.is_array()) return Bad(path, "glTF buffers that are not a list");
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  for (const Json& buffer : buffers) {
    const std::string uri = buffer.is_object() && buffer.contains("uri") && buffer["uri"].is_string()
                                ? buffer["uri"].get<std::string>()
                                : std::string();
    std::string data;
    std::string file;
    if (absl::StartsWith(uri, "data:")) {
      const size_t comma = uri.find(";base64,");
      if (comma == std::string::npos || !absl::Base64Unescape(uri.substr(comma + 8), &data)) {
        return Bad(path, "a glTF data URI that is not base64");
      }
    } else if (!uri.empty()) {
      file = (dir / uri).string();
      absl::StatusOr<std::string> read = ReadFileBytes(file);
      if (!read.ok()) return read.status();
      data = std::move(*read);
    }
    f.buffers.push_back(std::move(data));
    f.files.push_back(std::move(file));
  }
  return f;
}

// Calls `visit` with each v of every float VEC2 TEXCOORD_n accessor of every primitive.
absl::Status ForEachV(GltfFile& f, const std::function<void(char* v)>& visit) {
  const Json empty = Json::array();
  const Json& meshes = f.json.contains("meshes") ? f.json["meshes"] : empty;
  const Json& accessors = f.json.contains("accessors") ? f.json["accessors"] : empty;
  const Json& views = f.json.contains("bufferViews") ? f.json["bufferViews"] : empty;
  if (!meshes.is_array() || !accessors.is_array() || !views.is_array()) return Bad(f.path, "glTF lists that are not");
  for (const Json& mesh : meshes) {
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
    for (const Json& primitive : mesh["primitives"]) {
      if (!primitive.is_object() || !primitive.contains("attributes") || !primitive["attributes"].is_object()) continue;
      if (primitive.contains("extensions")) continue;  // Draco-compressed: its values are Draco's own
      for (const auto& [name, index] : primitive["attributes"].items()) {
        if (!absl::StartsWith(name, "TEXCOORD_") || !index.is_number_unsigned()) continue;
        const uint64_t a = index.get<uint64_t>();
        if (a >= accessors.size()) return Bad(f.path, "a glTF attribute past the accessors");
        const Json& accessor = accessors[a];
        if (!accessor.is_object() || accessor.contains("sparse") || Uint(accessor, "componentType", 0) != kFloat ||
            !accessor.contains("type") || accessor["type"] != "VEC2") {
          continue;
        }
        const int64_t v = Uint(accessor, "bufferView", -1), count = Uint(accessor, "count", -1);
        if (v < 0 || static_cast<uint64_t>(v) >= views.size() || count < 0) continue;
        const Json& view = views[v];
        const int64_t buffer = Uint(view, "buffer", -1), offset = Uint(view, "byteOffset", 0),
                      length = Uint(view, "byteLength", -1), stride = Uint(view, "byteStride", 8),
                      start = Uint(accessor, "byteOffset", 0);
        if (buffer < 0 || offset < 0 || length < 0 || stride < 8 || start < 0) return Bad(f.path, "a bad bufferView");
        char* data = nullptr;
        size_t size = 0;
        if (f.glb) {
          if (buffer != 0) return Bad(f.path, "a GLB accessor outside its BIN chunk");
          data = f.glb_bytes.data() + f.bin_offset;
          size = f.bin_size;
        } else {
          if (static_cast<size_t>(buffer) >= f.buffers.size()) return Bad(f.path, "a bufferView past the buffers");
          data = f.buffers[buffer].data();
          size = f.buffers[buffer].size();
        }
        if (count == 0) continue;
        // Every product and sum below stays under 2^64: each term is below 2^63.
        const uint64_t first_end = static_cast<uint64_t>(start) + 8;
        if (static_cast<uint64_t>(offset) + static_cast<uint64_t>(length) > size ||
            first_end > static_cast<uint64_t>(length) ||
            static_cast<uint64_t>(count - 1) >
                (static_cast<uint64_t>(length) - first_end) / static_cast<uint64_t>(stride)) {
          return Bad(f.path, "a texture coordinate accessor past its buffer");
        }
        for (int64_t i = 0; i < count; ++i) visit(data + offset + start + i * stride + 4);
      }
    }
  }
  return absl::OkStatus();
}

// What Draco's reader and writer make of `v`: float32(1 - float32(1 - v)), as its bits.
uint32_t RoundTrip(uint32_t v_bits) {
  float v;
  std::memcpy(&v, &v_bits, 4);
  const float read = static_cast<float>(1.0 - static_cast<double>(v));
  const float written = static_cast<float>(1.0 - static_cast<double>(read));
  uint32_t out;
  std::memcpy(&out, &written, 4);
  return out;
}

}  // namespace

absl::StatusOr<TexcoordOriginals> ReadTexcoordOriginals(const std::string& path) {
  absl::StatusOr<GltfFile> f = Load(path);
  if (!f.ok()) return f.status();
  TexcoordOriginals originals;
  absl::Status s = ForEachV(*f, [&originals](char* v) {
    const uint32_t bits = Le32({v, 4}, 0);
    auto [it, fresh] = originals.original_of.try_emplace(RoundTrip(bits), bits);
    if (!fresh && it->second != bits) it->second = kAmbiguous;
  });
  if (!s.ok()) return s;
  // A value Draco's round trip keeps needs nothing written back.
  std::erase_if(originals.original_of, [](const auto& entry) { return entry.first == entry.second; });
  return originals;
}

absl::StatusOr<int64_t> RestoreTexcoords(const std::string& path, const TexcoordOriginals& originals) {
  if (originals.original_of.empty()) return 0;  // nothing Draco changes: the file is not read again
  absl::StatusOr<GltfFile> f = Load(path);
  if (!f.ok()) return f.status();
  int64_t rewritten = 0;
  absl::Status s = ForEachV(*f, [&originals, &rewritten](char* v) {
    const uint32_t bits = Le32({v, 4}, 0);
    auto it = originals.original_of.find(bits);
    if (it == originals.original_of.end() || it->second == kAmbiguous || it->second == bits) return;
    std::memcpy(v, &it->second, 4);
    ++rewritten;
  });
  if (!s.ok()) return s;
  if (rewritten == 0) return rewritten;
  if (f->glb) {
    if (absl::Status w = WriteFileBytes(path, f->glb_bytes); !w.ok()) return w;
    return rewritten;
  }
  for (size_t b = 0; b < f->buffers.size(); ++b) {
    if (f->files[b].empty()) continue;
    if (absl::Status w = WriteFileBytes(f->files[b], f->buffers[b]); !w.ok()) return w;
  }
  return rewritten;
}

}  // namespace meshsmooth
