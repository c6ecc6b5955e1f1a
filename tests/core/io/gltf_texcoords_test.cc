// The texture coordinates of a glTF file as core/io/gltf_texcoords.h reads and rewrites them: the
// values of a float VEC2 accessor, and accessors that reach past their buffer refused, whatever
// their count and stride.
#include "core/io/gltf_texcoords.h"

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <string>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

// A .gltf of one primitive whose TEXCOORD_0 is `count` float VEC2s with `stride`, over a buffer
// (a data URI) of the texture coordinates (0.1, 0.1), (0.2, 0.3).
std::string Scene(const std::string& count, const std::string& stride) {
  const float uv[4] = {0.1f, 0.1f, 0.2f, 0.3f};
  const std::string bytes(reinterpret_cast<const char*>(uv), sizeof uv);
  return absl::StrCat(
      R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":16,"uri":"data:application/octet-stream;base64,)",
      absl::Base64Escape(bytes), R"("}],"bufferViews":[{"buffer":0,"byteLength":16)",
      stride.empty() ? "" : absl::StrCat(R"(,"byteStride":)", stride),
      R"(}],"accessors":[{"bufferView":0,"componentType":5126,"type":"VEC2","count":)", count,
      R"(}],"meshes":[{"primitives":[{"attributes":{"TEXCOORD_0":0}}]}]})");
}

std::string Write(const std::string& name, const std::string& json) {
  const std::string path = (std::filesystem::temp_directory_path() / absl::StrCat(getpid(), "_", name)).string();
  EXPECT_TRUE(WriteFileBytes(path, json).ok());
  return path;
}

TEST(GltfTexcoordsTest, ReadsEachVAndItsRoundTrip) {
  const std::string path = Write("uv.gltf", Scene("2", ""));
  absl::StatusOr<TexcoordOriginals> t = ReadTexcoordOriginals(path);
  ASSERT_TRUE(t.ok()) << t.status();
  // Each v Draco's round trip changes is listed under its round trip; one it keeps is not.
  size_t changed = 0;
  for (float v : {0.1f, 0.3f}) {
    const float trip = static_cast<float>(1.0 - static_cast<float>(1.0 - static_cast<double>(v)));
    uint32_t key, value;
    std::memcpy(&key, &trip, 4);
    std::memcpy(&value, &v, 4);
    if (key == value) {
      EXPECT_EQ(t->original_of.count(key), 0u) << v;
      continue;
    }
    ++changed;
    ASSERT_TRUE(t->original_of.count(key)) << v;
    EXPECT_EQ(t->original_of.at(key), value) << v;
  }
  EXPECT_GT(changed, 0u);  // 0.1 uses bits float32(1 - 0.1) does not have
  EXPECT_EQ(t->original_of.size(), changed);
  std::filesystem::remove(path);
}

TEST(GltfTexcoordsTest, AccessorsPastTheirBufferAreRefused) {
  for (const auto& [count, stride] : std::vector<std::pair<std::string, std::string>>{
           {"3", ""}, {"4611686018427387905", "8"}, {"2", "4611686018427387904"}, {"2", "4"}}) {
    SCOPED_TRACE(count + " / " + stride);
    const std::string path = Write("bad.gltf", Scene(count, stride));
    absl::StatusOr<TexcoordOriginals> t = ReadTexcoordOriginals(path);
    EXPECT_EQ(t.status().code(), absl::StatusCode::kInvalidArgument);
    std::filesystem::remove(path);
  }
}

}  // namespace
}  // namespace meshsmooth
