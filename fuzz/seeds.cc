// Writes the seed corpora of the fuzz targets (fuzz/run.sh runs it before each run; nothing
// of it is committed): small generated meshes in every format and Draco encoding, the small
// files (< 200 KB) of SHARED/data/draco and SHARED/data/meshes when present, and for the job
// target each Draco seed behind a few spec heads (job_input.h).
//
// Usage: fuzz_seeds OUT_DIR [SHARED_DIR]   writes OUT_DIR/{job,drc,ply,obj,off,stl}/
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "draco/io/gltf_encoder.h"
#include "draco/mesh/mesh.h"
#include "fuzz/job_input.h"

namespace meshsmooth::fuzz {
namespace {

namespace fs = std::filesystem;

constexpr uintmax_t kMaxSharedBytes = 200 * 1024;

// Heads by the kind of flow they suit (byte meanings in job_input.h); byte 0, the flow, is
// filled in for every flow of that kind in the table, so every flow gets seeds.
struct HeadTemplate {
  FlowKind kind;
  std::array<uint8_t, kSpecBytes> bytes;
};
constexpr HeadTemplate kTemplates[] = {
    {FlowKind::kUmbrella, {0, 1, 0, 0, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0}},          // U1, boundary as curves
    {FlowKind::kUmbrella, {0, 2, 0, 0, 0, 0, 0, 0, 1, 200, 0, 0, 0, 0}},        // taubin's mu
    {FlowKind::kUmbrella, {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0}},          // features
    {FlowKind::kCurvature, {0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 128 + 12, 0, 0}},  // Edgebreaker, 12 bits
    {FlowKind::kCurvature, {0, 1, 0, 0, 0, 0, 2, 0x15, 0, 0, 0, 20, 0, 0}},     // ring1, 20 bits
    {FlowKind::kCurvature, {0, 2, 0, 0, 0, 2, 3, 0x15, 0, 0, 3, 128, 0, 0}},    // ring2, features, Edgebreaker
    {FlowKind::kCurvature, {0, 0, 0, 0, 0, 0, 1, 0x20, 0x18, 60, 0, 0, 0, 0}},  // constant T, epsilon, tolerance
    {FlowKind::kNormalFilter, {0, 1, 0, 0, 0, 2, 0, 0, 0, 0, 0, 8, 15, 9}},     // every filter parameter
};

std::vector<std::array<uint8_t, kSpecBytes>> Heads() {
  std::vector<std::array<uint8_t, kSpecBytes>> heads;
  for (size_t f = 0; f < FlowNames().size(); ++f) {
    const FlowKind kind = KindOf(static_cast<FlowId>(f));
    for (const HeadTemplate& t : kTemplates) {
      if (t.kind != kind) continue;
      heads.push_back(t.bytes);
      heads.back()[0] = static_cast<uint8_t>(f);
    }
  }
  return heads;
}

void WriteFile(const fs::path& path, std::string_view bytes) {
  if (const absl::Status s = WriteFileBytes(path.string(), bytes); !s.ok()) {
    std::fprintf(stderr, "fuzz_seeds: %s\n", s.ToString().c_str());
    std::exit(1);
  }
}

class SeedWriter {
 public:
  explicit SeedWriter(fs::path out) : out_(std::move(out)) {
    for (const char* d : {"job", "drc", "ply", "obj", "off", "stl", "gltf"}) fs::create_directories(out_ / d);
  }

  void Add(const std::string& dir, const std::string& name, const std::string& bytes) {
    WriteFile(out_ / dir / name, bytes);
    if (dir == "drc") AddJob(name, bytes);
  }

  // Every format and Draco encoding of a generated mesh.
  void AddMesh(const std::string& name, const Mesh& mesh) {
    WriteOptions ascii;
    ascii.ply_binary = false;
    for (const auto& [file, format, options] : {std::tuple{name + ".ply", MeshFormat::kPly, WriteOptions{}},
                                                std::tuple{name + "_ascii.ply", MeshFormat::kPly, ascii},
                                                std::tuple{name + ".obj", MeshFormat::kObj, WriteOptions{}},
                                                std::tuple{name + ".off", MeshFormat::kOff, WriteOptions{}},
                                                std::tuple{name + ".stl", MeshFormat::kStl, WriteOptions{}}}) {
      absl::StatusOr<std::string> bytes = SerializeMesh(mesh, format, options);
      if (bytes.ok()) Add(file.substr(file.rfind('.') + 1), file, *bytes);
    }
    const DracoOptions encodings[] = {{0, DracoMethod::kSequential},
                                      {0, DracoMethod::kEdgebreaker},
                                      {11, DracoMethod::kSequential},
                                      {8, DracoMethod::kEdgebreaker}};
    for (const DracoOptions& o : encodings) {
      absl::StatusOr<std::string> bytes = EncodeDraco(mesh, o);
      if (!bytes.ok()) continue;
      Add("drc", absl::StrCat(name, o.method == DracoMethod::kSequential ? "_seq" : "_eb", o.quantization_bits, ".drc"),
          *bytes);
    }
  }

  // The small files of a shared data folder, by extension; meshes of other formats also go to
  // the job corpus as the CLI would upload them (Draco, lossless, sequential). Taken in name
  // order: each upload's pair of job heads follows its rank, and the corpus must not depend on
  // the order the file system lists a folder in.
  void AddShared(const fs::path& dir) {
    if (!fs::is_directory(dir)) return;
    std::vector<fs::directory_entry> entries(fs::directory_iterator(dir), fs::directory_iterator{});
    std::sort(entries.begin(), entries.end(),
              [](const fs::directory_entry& a, const fs::directory_entry& b) { return a.path() < b.path(); });
    for (const fs::directory_entry& e : entries) {
      if (!e.is_regular_file() || e.file_size() >= kMaxSharedBytes) continue;
      const std::string ext = e.path().extension().string();
      if (ext != ".drc" && ext != ".ply" && ext != ".obj" && ext != ".off" && ext != ".stl") continue;
      const absl::StatusOr<std::string> read = ReadFileBytes(e.path().string());
      if (!read.ok()) continue;
      const std::string& bytes = *read;
      const std::string name = e.path().filename().string();
      Add(ext.substr(1), name, bytes);
      if (ext == ".drc") continue;
      absl::StatusOr<MeshFormat> format = FormatFromPath(name);
      absl::StatusOr<Mesh> mesh = format.ok() ? ParseMesh(bytes, *format) : format.status();
      if (!mesh.ok()) continue;
      absl::StatusOr<std::string> drc = EncodeDraco(*mesh);
      if (drc.ok()) AddJob(name + ".drc", *drc);
    }
  }

 private:
  // Two heads per upload, a different pair for each.
  void AddJob(const std::string& name, const std::string& upload) {
    for (size_t k : {jobs_ % heads_.size(), (jobs_ + 3) % heads_.size()}) {
      std::string bytes(heads_[k].begin(), heads_[k].end());
      WriteFile(out_ / "job" / absl::StrCat(name, ".h", k), bytes + upload);
    }
    ++jobs_;
  }

  fs::path out_;
  const std::vector<std::array<uint8_t, kSpecBytes>> heads_ = Heads();
  size_t jobs_ = 0;
};

// A tetrahedron with what a hostile or careless writer leaves in: a face with an index out of
// range, one with a repeated index, an isolated vertex and a third face on one edge.
Mesh Odd() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {5, 5, 5}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}, {0, 1, 4}, {0, 1, 7}, {2, 2, 3}};
  return m;
}

// A one-primitive glTF scene of `mesh` (positions, lat-long texture coordinates), as GLB bytes:
// Draco-compressed or plain. Empty when Draco's encoder fails.
std::string GlbSeed(const Mesh& mesh, bool compressed) {
  auto dm = std::make_unique<draco::Mesh>();
  const uint32_t n = static_cast<uint32_t>(mesh.num_vertices());
  dm->set_num_points(n);
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 12, 0);
  draco::PointAttribute* pos = dm->attribute(dm->AddAttribute(ga, true, n));
  ga.Init(draco::GeometryAttribute::TEX_COORD, nullptr, 2, draco::DT_FLOAT32, false, 8, 0);
  draco::PointAttribute* uv = dm->attribute(dm->AddAttribute(ga, true, n));
  for (uint32_t p = 0; p < n; ++p) {
    const Vec3& q = mesh.positions[p];
    const float xyz[3] = {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
    const float st[2] = {static_cast<float>(0.5 + 0.5 * q.x), static_cast<float>(0.5 + 0.5 * q.y)};
    pos->SetAttributeValue(draco::AttributeValueIndex(p), xyz);
    uv->SetAttributeValue(draco::AttributeValueIndex(p), st);
  }
  for (const Triangle& t : mesh.triangles) {
    dm->AddFace({draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
  }
  dm->SetCompressionEnabled(compressed);
  draco::EncoderBuffer buffer;
  draco::GltfEncoder encoder;
  if (!encoder.EncodeToBuffer(*dm, &buffer).ok()) return {};
  return std::string(buffer.data(), buffer.size());
}

}  // namespace
}  // namespace meshsmooth::fuzz

int main(int argc, char** argv) {
  using namespace meshsmooth;
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: %s OUT_DIR [SHARED_DIR]\n", argv[0]);
    return 2;
  }
  fuzz::SeedWriter seeds(argv[1]);
  Mesh noisy = Icosphere(2);
  AddUniformNoise(noisy, 0.2, 1);
  Mesh colored = Icosphere(1);
  for (int32_t i = 0; i < colored.num_vertices(); ++i) {
    colored.colors.push_back({static_cast<uint8_t>(i * 7), static_cast<uint8_t>(i * 13), static_cast<uint8_t>(i)});
  }
  // A scan's attributes: per-corner UVs with a seam (the first face's corners name their own
  // entries), per-vertex normals, a float property and OBJ material lines.
  Mesh textured = colored;
  textured.uvs.components = 2;
  textured.normals.components = 3;
  for (const Vec3& p : textured.positions) {
    textured.uvs.values.insert(textured.uvs.values.end(), {0.5 + 0.5 * p.x, 0.5 + 0.5 * p.y});
    textured.normals.values.insert(textured.normals.values.end(), {p.x, p.y, p.z});
  }
  for (const Triangle& t : textured.triangles) {
    textured.uvs.corners.insert(textured.uvs.corners.end(), t.begin(), t.end());
    textured.normals.corners.insert(textured.normals.corners.end(), t.begin(), t.end());
  }
  for (int k = 0; k < 3; ++k) {
    textured.uvs.corners[k] = static_cast<int32_t>(textured.uvs.values.size() / 2);
    textured.uvs.values.insert(textured.uvs.values.end(), {1.0 + k, 0.25});
  }
  textured.properties.push_back({"confidence", "float", std::vector<double>(textured.positions.size(), 0.5)});
  textured.obj_directives = {{0, "mtllib a.mtl"}, {0, "usemtl skin"}, {4, "g rest"}};
  seeds.AddMesh("textured_icosphere1", textured);
  seeds.AddMesh("icosphere1", Icosphere(1));
  seeds.AddMesh("noisy_icosphere2", noisy);
  seeds.AddMesh("colored_icosphere1", colored);
  seeds.AddMesh("torus", TwoRateTorus(8));
  seeds.AddMesh("plane", TwoRatePlane(4, 4));
  seeds.AddMesh("cylinder", Cylinder(0.5, 1.0, 8, 3));
  seeds.AddMesh("odd", fuzz::Odd());
  for (bool compressed : {false, true}) {
    const std::string glb = fuzz::GlbSeed(Icosphere(1), compressed);
    if (!glb.empty()) seeds.Add("gltf", compressed ? "icosphere1_draco.glb" : "icosphere1.glb", glb);
  }
  if (argc == 3) {
    seeds.AddShared(fuzz::fs::path(argv[2]) / "data" / "draco");
    seeds.AddShared(fuzz::fs::path(argv[2]) / "data" / "meshes");
  }
  return 0;
}
