// libFuzzer target: the glTF path (core/io/gltf.h) as the CLI takes it. Bytes -> a .glb file ->
// GltfScene::ReadInChildFirst (Draco's glTF decoder and encoder, and our code around them, first
// in a child process). A refusal must be INVALID_ARGUMENT: a file Draco refuses, or one that
// crashes the child in Draco's own frames (Draco 1.5.5 crashes on some malformed files), whose
// crash report goes to the log. A crash of the child in meshsmooth's frames, or in frames that
// name neither, is INTERNAL and a finding. A scene read must hold:
//   - its surface has triangles, every index in range;
//   - written back with its own positions, plain and Draco-compressed, it reads again with the
//     same nodes, meshes, primitives, materials and textures.
// Any violation aborts, so libFuzzer keeps the input.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/io/crash_report.h"
#include "core/io/file_bytes.h"
#include "core/io/gltf.h"

namespace meshsmooth::fuzz {
namespace {

void Check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "glTF fuzz target: invariant violated: %s\n", what);
  std::abort();
}

// A file of this process's own in the temporary folder, removed at exit.
std::string TempPath(const char* name) {
  static const std::filesystem::path dir = [] {
    std::filesystem::path d =
        std::filesystem::temp_directory_path() / ("meshsmooth_fuzz_gltf_" + std::to_string(getpid()));
    std::filesystem::create_directories(d);
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(
          std::filesystem::temp_directory_path() / ("meshsmooth_fuzz_gltf_" + std::to_string(getpid())), ignored);
    });
    return d;
  }();
  return (dir / name).string();
}

}  // namespace
}  // namespace meshsmooth::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace meshsmooth;
  const std::string in = fuzz::TempPath("in.glb");
  fuzz::Check(WriteFileBytes(in, std::string_view(reinterpret_cast<const char*>(data), size)).ok(),
              "cannot write the input file");
  absl::StatusOr<GltfScene> scene = GltfScene::ReadInChildFirst(in, /*draco_compressed=*/true);
  if (!scene.ok()) {
    if (const auto report = scene.status().GetPayload(kCrashReportPayload); report.has_value()) {
      std::fprintf(stderr, "glTF fuzz target: %s\nThe child's crash report:\n%s\n",
                   std::string(scene.status().message()).c_str(), std::string(*report).c_str());
    }
    fuzz::Check(scene.status().code() == absl::StatusCode::kInvalidArgument,
                "a refusal that is not INVALID_ARGUMENT (a crash outside Draco's code is INTERNAL)");
    return 0;
  }
  const Mesh& s = scene->surface();
  fuzz::Check(!s.triangles.empty(), "a scene read without triangles");
  for (const Triangle& t : s.triangles) {
    for (int32_t i : t) fuzz::Check(i >= 0 && i < s.num_vertices(), "a surface index out of range");
  }
  const GltfCounts counts = scene->counts();
  for (bool draco : {false, true}) {
    const std::string out = fuzz::TempPath(draco ? "out-draco.glb" : "out.glb");
    if (!scene->Write(s.positions, out, draco).ok()) continue;  // e.g. Draco cannot compress it
    absl::StatusOr<GltfScene> back = GltfScene::Read(out);
    fuzz::Check(back.ok(), "a scene written does not read again");
    fuzz::Check(back->counts() == counts, "written back, the scene's counts changed");
  }
  return 0;
}
