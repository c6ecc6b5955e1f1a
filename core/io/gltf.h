// glTF 2.0 scenes (.gltf with its buffers and images, .glb), plain or with Draco-compressed
// primitives (KHR_draco_mesh_compression), read and written by Draco's own transcoder
// (draco::GltfDecoder, draco::GltfEncoder): the scene's nodes and their transforms, meshes,
// materials, textures and images come back as they were, only the primitives' positions (and
// normals, recomputed from them) change; plain output's texture coordinates are the input file's
// own, bit for bit (Draco's round trip of them is undone: gltf_texcoords.h).
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/mesh.h"

namespace meshsmooth {

// Registers Draco's stdio file reader and writer with its file factories, once. They join from
// static initialisers in their own object files, which a program linking libdraco.a
// (cmake/StaticDependencies.cmake) does not pull in: without this, Draco's own file functions
// (draco::ReadSceneFromFile, WriteSceneToFile, ReadMeshFromFile) open no file. GltfScene calls
// it; a caller of those functions calls it first.
void UseDracoFileIo();

// What a scene holds, for the record and the tests.
struct GltfCounts {
  int nodes = 0, meshes = 0, primitives = 0, materials = 0, textures = 0;
  friend bool operator==(const GltfCounts&, const GltfCounts&) = default;
};

// Writes a mesh as a glTF scene at `path` (.glb, or .gltf with OUT.bin beside it): `bytes`
// holds it as the service returns it (positions relative to `origin`, texture coordinates,
// normals, colours), one node translated by `origin` places it (how glTF georeferences a mesh:
// its float32 positions stay near zero), primitives Draco-compressed when `draco_compressed`.
// What glTF has no place for (one-component vertex properties) is named in `dropped`.
// InvalidArgument for bytes Draco cannot decode; Internal when its encoder fails.
absl::Status WriteMeshAsGltf(std::string_view bytes, const Vec3& origin, const std::string& path, bool draco_compressed,
                             std::vector<std::string>* dropped);

class GltfScene {
 public:
  // InvalidArgument (with Draco's message) for a file Draco's glTF decoder refuses, or one
  // without a triangle primitive; NotFound for a missing file.
  static absl::StatusOr<GltfScene> Read(const std::string& path);
  // Read, after reading the file once in a forked child process and writing the scene it
  // reads there (as .glb, plain and, with `draco_compressed`, Draco-compressed, to a temporary
  // file). Draco 1.5.5's glTF reading and writing crash on some malformed files (a null
  // dereference in its copy of tinygltf, heap overflows in its triangle-soup builder, a wild
  // write in its entropy coder: docs/development.md), which no check of ours can stop before
  // Draco parses them. A child that dies (a signal, or a sanitizer's exit) leaves a crash report
  // (core/io/crash_report.h) whose stack says whose code crashed: in Draco's, the file is refused
  // (InvalidArgument, "... Draco's glTF reader crashed on it (SEGV in tinygltf::ParseMesh
  // <- ...)"); in meshsmooth's, or where no frame names either, the status is Internal ("...
  // a bug in meshsmooth, please report it ..."). Either carries the report as its
  // kCrashReportPayload. Fork-safe only where no other thread holds a lock: call it before
  // starting threads.
  static absl::StatusOr<GltfScene> ReadInChildFirst(const std::string& path, bool draco_compressed);

  GltfScene(GltfScene&&) noexcept;
  GltfScene& operator=(GltfScene&&) noexcept;
  ~GltfScene();

  // Every triangle primitive's points as one mesh, primitive after primitive, positions in
  // their glTF mesh's own frame (node transforms stay in the scene). The primitives of one glTF
  // mesh share that frame, so where they share positions a welding service makes them one
  // surface; the glTF meshes after the first are moved apart along x by more than any mesh's
  // extent, so that no two of them weld.
  const Mesh& surface() const;

  GltfCounts counts() const;

  // What the scene holds that smoothing leaves stale (tangents), one phrase each.
  std::vector<std::string> stale() const;

  // Sets the primitives' positions from `positions` (one per vertex of surface(), in its
  // frame: the offsets between glTF meshes are taken back off), recomputes the normals of those
  // that have them (area-weighted over the faces at each position) and writes the scene to
  // `path` (.glb: one file; .gltf: the JSON with STEM.bin and STEM_IMAGE.EXT beside it, named
  // after the output so that no other file is replaced), each
  // primitive Draco-compressed when `draco_compressed` (16-bit positions and texture
  // coordinates, 12-bit normals) or plain. InvalidArgument for a wrong count; Internal when
  // Draco's encoder fails.
  absl::Status Write(const std::vector<Vec3>& positions, const std::string& path, bool draco_compressed);

 private:
  struct Impl;
  explicit GltfScene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshsmooth
