// Every input format x every output format x {at the origin, georeferenced} x {plain, with
// attributes}, through the meshsmooth CLI and a real meshsmoothd (started here on a free loopback
// port), the output written into the input's own folder:
// - the job succeeds;
// - no file but the output and files named after it (OUT.bin, OUT_IMAGE.png) is created or
//   changed in the folder (its bytes compared before and after);
// - a vertex the job does not move (the boundary, kept by --boundary fixed) comes back exactly as
//   read from the input in every output that can hold the input's precision, and within
//   float32's step of it otherwise; a moved vertex matches the same job's .obj output within the
//   output format's precision, and that output lies near the input (the origin added back);
// - attributes the output format holds come back with the input's values; those it cannot hold
//   are named in the warning line and in the --json summary, as are coordinates written in
//   float32 far from the origin.
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/io/draco_codec.h"
#include "core/io/file_bytes.h"
#include "core/io/gltf.h"
#include "core/io/gltf_texcoords.h"
#include "core/io/mesh_io.h"
#include "core/shapes/parametric.h"
#include "draco/io/scene_io.h"
#include "draco/scene/scene.h"
#include "gtest/gtest.h"
#include "tests/gltf_fixtures.h"

namespace meshsmooth::testing {
namespace {

namespace fs = std::filesystem;

const Vec3 kSurvey{512345.25, 5412345.75, 231.5};  // UTM metres and an elevation
constexpr double kSide = 100.0;                    // the patch: 100 m, edges of 4 to 12 m

// meshsmoothd on a free loopback port for the whole suite.
class Daemon {
 public:
  Daemon() {
    int fds[2];
    if (pipe(fds) != 0) return;
    pid_ = fork();
    if (pid_ == 0) {
      dup2(fds[1], 1);
      close(fds[0]);
      // Its job log lines (stderr) are not what this test reads.
      if (int null = open("/dev/null", O_WRONLY); null >= 0) dup2(null, 2);
      execl(MESHSMOOTHD_BINARY, MESHSMOOTHD_BINARY, "--listen", "127.0.0.1:0", static_cast<char*>(nullptr));
      _exit(127);
    }
    close(fds[1]);
    FILE* out = fdopen(fds[0], "r");
    char line[256];
    while (out != nullptr && std::fgets(line, sizeof line, out) != nullptr) {
      int port = 0;
      if (std::sscanf(line, "meshsmoothd listening on 127.0.0.1:%d", &port) == 1) {
        target_ = absl::StrCat("127.0.0.1:", port);
        break;
      }
    }
    out_ = out;  // kept open: the server's later lines go nowhere else
  }
  ~Daemon() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
    if (out_ != nullptr) std::fclose(out_);
  }
  const std::string& target() const { return target_; }

 private:
  pid_t pid_ = -1;
  FILE* out_ = nullptr;
  std::string target_;
};

struct Variant {
  bool georeferenced;
  bool attributes;
};

// The input: a 100 m plane patch with a wavy, non-float32 height, at the origin or at survey
// coordinates; with attributes, per-vertex texture coordinates (exact in float32), colours, a
// constant normal and a property.
Mesh Patch(const Variant& v) {
  Mesh m = TwoRatePlane(12, 8);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    Vec3& p = m.positions[i];
    const Vec3 uv{p.x, p.y, 0.0};
    p = {kSide * p.x + 1e-7 * i, kSide * p.y + 3e-7 * i, 0.5 * std::sin(0.37 * i) + 1e-9 * i};
    if (v.georeferenced) p += kSurvey;
    if (!v.attributes) continue;
    m.uvs.components = 2;
    // float32 values with every bit used (Draco's glTF path rounds v below 0.5 when it can).
    m.uvs.values.push_back(static_cast<float>(0.9 * uv.x + 0.01));
    m.uvs.values.push_back(static_cast<float>(0.37 * uv.y + 0.01 + 0.001 * uv.x));
    m.colors.push_back({static_cast<uint8_t>(i % 256), static_cast<uint8_t>(7 * i % 256), 200});
  }
  if (v.attributes) {
    m.uvs.corners.clear();
    for (const Triangle& t : m.triangles) m.uvs.corners.insert(m.uvs.corners.end(), t.begin(), t.end());
    m.normals.components = 3;
    m.normals.values = {0.0, 0.0, 1.0};
    m.normals.corners.assign(3 * m.triangles.size(), 0);
    VertexProperty confidence{"confidence", "float", {}};
    for (size_t i = 0; i < m.positions.size(); ++i) confidence.values.push_back(static_cast<double>(i % 17) / 16.0);
    m.properties.push_back(confidence);
  }
  return m;
}

// A scene of `m` (positions, and with attributes texture coordinates, normals and a texture) in
// one node, translated to survey coordinates when georeferenced (how glTF places a scan).
std::unique_ptr<draco::Scene> PatchScene(const Mesh& m, const Variant& v) {
  auto dm = std::make_unique<draco::Mesh>();
  const uint32_t n = static_cast<uint32_t>(m.positions.size());
  dm->set_num_points(n);
  auto add = [&](draco::GeometryAttribute::Type type, int components) {
    return AddFloatAttribute(*dm, type, components, n);
  };
  draco::PointAttribute* pos = add(draco::GeometryAttribute::POSITION, 3);
  draco::PointAttribute* uv = v.attributes ? add(draco::GeometryAttribute::TEX_COORD, 2) : nullptr;
  draco::PointAttribute* nrm = v.attributes ? add(draco::GeometryAttribute::NORMAL, 3) : nullptr;
  for (uint32_t p = 0; p < n; ++p) {
    const Vec3 q = v.georeferenced ? m.positions[p] - kSurvey : m.positions[p];
    const float xyz[3] = {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
    pos->SetAttributeValue(draco::AttributeValueIndex(p), xyz);
    if (!v.attributes) continue;
    // Draco holds v flipped (1 - v) and flips it as it writes the file.
    const float st[2] = {static_cast<float>(m.uvs.values[2 * p]),
                         static_cast<float>(1.0 - static_cast<float>(m.uvs.values[2 * p + 1]))};
    uv->SetAttributeValue(draco::AttributeValueIndex(p), st);
    const float up[3] = {0.0f, 0.0f, 1.0f};
    nrm->SetAttributeValue(draco::AttributeValueIndex(p), up);
  }
  for (const Triangle& t : m.triangles) {
    dm->AddFace({draco::PointIndex(t[0]), draco::PointIndex(t[1]), draco::PointIndex(t[2])});
  }
  auto scene = std::make_unique<draco::Scene>();
  const draco::MeshIndex mi = scene->AddMesh(std::move(dm));
  draco::MaterialLibrary& materials = scene->GetMaterialLibrary();
  draco::Material* skin = materials.MutableMaterial(0);
  if (v.attributes) {
    const absl::StatusOr<std::string> png = GreyPng();
    EXPECT_TRUE(png.ok());
    auto texture = std::make_unique<draco::Texture>();
    texture->source_image().MutableEncodedData().assign(png->begin(), png->end());
    texture->source_image().set_mime_type("image/png");
    const int t = materials.MutableTextureLibrary().PushTexture(std::move(texture));
    EXPECT_TRUE(skin->SetTextureMap(materials.MutableTextureLibrary().GetTexture(t), draco::TextureMap::COLOR, 0).ok());
  }
  const draco::MeshGroupIndex g = scene->AddMeshGroup();
  scene->GetMeshGroup(g)->AddMeshInstance({mi, 0});
  const draco::SceneNodeIndex node = scene->AddNode();
  scene->GetNode(node)->SetMeshGroupIndex(g);
  if (v.georeferenced) {
    draco::TrsMatrix trs;
    trs.SetTranslation(Eigen::Vector3d(kSurvey.x, kSurvey.y, kSurvey.z));
    scene->GetNode(node)->SetTrsMatrix(trs);
  }
  scene->AddRootNodeIndex(node);
  return scene;
}

struct Input {
  std::string name;  // the file's name
  std::function<absl::Status(const Mesh&, const Variant&, const std::string&)> write;
  bool holds_attributes;
  bool gltf = false;
};

std::vector<Input> Inputs() {
  auto mesh_writer = [](bool binary, bool dbl) {
    return [binary, dbl](const Mesh& m, const Variant&, const std::string& path) {
      WriteOptions o;
      o.ply_binary = binary;
      o.ply_double = dbl;
      return WriteMesh(path, m, o);
    };
  };
  auto scene_writer = [](const Mesh& m, const Variant& v, const std::string& path) {
    UseDracoFileIo();
    const draco::Status s = draco::WriteSceneToFile(path, *PatchScene(m, v));
    if (!s.ok() || !v.attributes) return s.ok() ? absl::OkStatus() : absl::InternalError(s.error_msg());
    // Draco's writer leaves only values its own round trip keeps; a scan's tools write every bit.
    TexcoordOriginals full;
    for (size_t i = 1; i < m.uvs.values.size(); i += 2) {
      const float want = static_cast<float>(m.uvs.values[i]);
      const float written = static_cast<float>(1.0 - static_cast<float>(1.0 - want));
      uint32_t key, value;
      std::memcpy(&key, &written, 4);
      std::memcpy(&value, &want, 4);
      full.original_of[key] = value;
    }
    absl::StatusOr<int64_t> n = RestoreTexcoords(path, full);
    return n.ok() ? absl::OkStatus() : n.status();
  };
  return {
      {"in.obj", mesh_writer(true, false), true},
      {"in-ascii-float.ply", mesh_writer(false, false), true},
      {"in-ascii-double.ply", mesh_writer(false, true), true},
      {"in-binary-float.ply", mesh_writer(true, false), true},
      {"in-binary-double.ply", mesh_writer(true, true), true},
      {"in.off", mesh_writer(true, false), false},
      {"in.stl", mesh_writer(true, false), false},
      {"in.drc", mesh_writer(true, false), true},
      {"in.gltf", scene_writer, true, true},
      {"in.glb", scene_writer, true, true},
  };
}

// Every regular file under `dir` with its bytes.
std::map<std::string, std::string> Snapshot(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    absl::StatusOr<std::string> bytes = ReadFileBytes(e.path().string());
    files[fs::relative(e.path(), dir).string()] = bytes.ok() ? *bytes : "<unreadable>";
  }
  return files;
}

struct CliRun {
  int exit_code = -1;
  std::string json, err;
};

// `meshsmooth smooth DIR/IN -o DIR/OUT --server TARGET` with `job` (flow options), its stdout
// and stderr kept beside DIR.
CliRun Smooth(const std::string& target, const fs::path& dir, const std::string& in, const std::string& out,
              const std::string& job = "--flow laplacian --iterations 3 --boundary fixed") {
  const std::string json = (dir.parent_path() / "stdout.json").string(),
                    err = (dir.parent_path() / "stderr.txt").string();
  const std::string command =
      absl::StrCat("'", MESHSMOOTH_BINARY, "' smooth '", (dir / in).string(), "' -o '", (dir / out).string(),
                   "' --server ", target, " ", job, " --json >'", json, "' 2>'", err, "'");
  CliRun r;
  const int status = std::system(command.c_str());
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.json = ReadFileBytes(json).value_or("");
  r.err = ReadFileBytes(err).value_or("");
  return r;
}

// Per vertex of `m`, the patch: whether it lies on the square's border (the boundary).
std::vector<bool> Border(const Mesh& m) {
  BoundingBox box;
  for (const Vec3& p : m.positions) box.Add(p);
  std::vector<bool> border;
  for (const Vec3& p : m.positions) {
    border.push_back(std::fabs(p.x - box.lo.x) < 1e-3 || std::fabs(p.x - box.hi.x) < 1e-3 ||
                     std::fabs(p.y - box.lo.y) < 1e-3 || std::fabs(p.y - box.hi.y) < 1e-3);
  }
  return border;
}

// The positions of each triangle's corners, triangle after triangle (formats that reorder or
// weld vertices, such as STL, keep the triangles' order).
std::vector<Vec3> Corners(const Mesh& m) {
  std::vector<Vec3> out;
  for (const Triangle& t : m.triangles) {
    for (int32_t v : t) out.push_back(m.positions[v]);
  }
  return out;
}

// float32's step at the largest coordinate of `p`.
double Step(const Vec3& p) {
  const float f = static_cast<float>(std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)}));
  return static_cast<double>(std::nextafter(f, HUGE_VALF)) - static_cast<double>(f);
}

bool Near(const Vec3& a, const Vec3& b, double tolerance) {
  return std::fabs(a.x - b.x) <= tolerance && std::fabs(a.y - b.y) <= tolerance && std::fabs(a.z - b.z) <= tolerance;
}

class IoMatrixTest : public ::testing::TestWithParam<Variant> {
 protected:
  static void SetUpTestSuite() { daemon_ = new Daemon(); }
  static void TearDownTestSuite() {
    delete daemon_;
    daemon_ = nullptr;
  }
  static Daemon* daemon_;
};
Daemon* IoMatrixTest::daemon_ = nullptr;

TEST_P(IoMatrixTest, EveryFormatToEveryFormat) {
  ASSERT_FALSE(daemon_->target().empty()) << "meshsmoothd did not start";
  const Variant v = GetParam();
  const fs::path root =
      fs::temp_directory_path() / absl::StrCat("meshsmooth_io_matrix_", getpid(), "_", v.georeferenced, v.attributes);
  fs::remove_all(root);
  const Mesh patch = Patch(v);
  for (const Input& input : Inputs()) {
    if (v.attributes && !input.holds_attributes) continue;  // the plain run covers it
    const fs::path dir = root / input.name;
    fs::create_directories(dir);
    ASSERT_TRUE(input.write(patch, v, (dir / input.name).string()).ok()) << input.name;
    const std::vector<std::string> outputs =
        input.gltf ? std::vector<std::string>{"out.gltf", "out.glb"}
                   : std::vector<std::string>{"ref.obj", "out.obj", "out.ply",  "out.off",
                                              "out.stl", "out.drc", "out.gltf", "out.glb"};
    // The input as it reads back (float formats have rounded it): the truth every output is held to.
    Mesh truth;
    if (input.gltf) {
      absl::StatusOr<GltfScene> scene = GltfScene::Read((dir / input.name).string());
      ASSERT_TRUE(scene.ok()) << scene.status();
      truth = scene->surface();
    } else {
      absl::StatusOr<Mesh> read = ReadMesh((dir / input.name).string());
      ASSERT_TRUE(read.ok()) << read.status();
      truth = std::move(*read);
    }
    const std::vector<bool> boundary = Border(truth);
    std::vector<Vec3> reference;  // the .obj output's corners
    for (const std::string& output : outputs) {
      SCOPED_TRACE(absl::StrCat(input.name, " -> ", output, v.georeferenced ? ", georeferenced" : ", at the origin",
                                v.attributes ? ", with attributes" : ", plain"));
      const std::map<std::string, std::string> before = Snapshot(dir);
      const CliRun run = Smooth(daemon_->target(), dir, input.name, output);
      ASSERT_EQ(run.exit_code, 0) << run.err;
      // Nothing but the output and files named after it created or changed.
      const std::string stem = fs::path(output).stem().string();
      for (const auto& [name, bytes] : Snapshot(dir)) {
        const bool ours = name == output || name == stem + ".bin" || absl::StartsWith(name, stem + "_");
        if (ours) continue;
        auto it = before.find(name);
        EXPECT_TRUE(it != before.end()) << "created " << name;
        if (it != before.end()) {
          EXPECT_TRUE(it->second == bytes) << "changed " << name;
        }
      }
      for (const auto& [name, bytes] : before) EXPECT_TRUE(fs::exists(dir / name)) << "removed " << name;
      // What the output holds; a glTF output of another input places it with its node's
      // translation (`offset`).
      const bool gltf_output = fs::path(output).extension() != ".obj" && fs::path(output).extension() != ".ply" &&
                               fs::path(output).extension() != ".off" && fs::path(output).extension() != ".stl" &&
                               fs::path(output).extension() != ".drc";
      Mesh out;
      Vec3 offset;
      bool out_uvs = false, out_colors = false;
      if (gltf_output) {
        absl::StatusOr<GltfScene> scene = GltfScene::Read((dir / output).string());
        ASSERT_TRUE(scene.ok()) << scene.status();
        if (input.gltf) {
          EXPECT_EQ(scene->counts(), GltfScene::Read((dir / input.name).string())->counts());
        }
        out = scene->surface();
        UseDracoFileIo();
        auto raw = draco::ReadSceneFromFile((dir / output).string());
        ASSERT_TRUE(raw.ok());
        const auto t = raw.value()->GetNode(draco::SceneNodeIndex(0))->GetTrsMatrix().Translation();
        if (!input.gltf && t.ok()) offset = {t.value().x(), t.value().y(), t.value().z()};
        const draco::Mesh& first = raw.value()->GetMesh(draco::MeshIndex(0));
        out_uvs = first.GetNamedAttribute(draco::GeometryAttribute::TEX_COORD) != nullptr;
        out_colors = first.GetNamedAttribute(draco::GeometryAttribute::COLOR) != nullptr;
        for (Vec3& p : out.positions) p += offset;
      } else {
        absl::StatusOr<Mesh> read = ReadMesh((dir / output).string());
        ASSERT_TRUE(read.ok()) << read.status();
        out = std::move(*read);
      }
      ASSERT_EQ(out.triangles.size(), truth.triangles.size());
      const std::vector<Vec3> in_corners = Corners(truth), out_corners = Corners(out);
      const bool float32 = gltf_output || output == "out.stl" || output == "out.drc";
      // The CLI sends a mesh far from the origin relative to one (a .drc input as it is).
      const bool far = v.georeferenced && !input.gltf && input.name != "in.drc";
      // Float32 far from the origin is a loss the warning names, in both places.
      const bool lossy = far && (output == "out.stl" || output == "out.drc");
      EXPECT_EQ(absl::StrContains(run.err, "holds float32"), lossy) << run.err;
      EXPECT_EQ(absl::StrContains(run.json, "holds float32"), lossy) << run.json;
      int64_t unmoved_off = 0, moved = 0, moved_off = 0;
      for (size_t c = 0; c < in_corners.size(); ++c) {
        const Vec3& want = in_corners[c];
        const Vec3& got = out_corners[c];
        if (boundary[truth.triangles[c / 3][c % 3]] && !input.gltf) {
          // Exact where the output holds the input's precision.
          const bool exact = !float32 || RoundToFloat(want) == want;
          unmoved_off += exact ? !(got == want) : !Near(got, want, Step(want - offset));
          continue;
        }
        if (input.gltf) {
          unmoved_off += boundary[truth.triangles[c / 3][c % 3]] && !(got == want);
          continue;
        }
        moved += !(got == want);
        if (output == "ref.obj") {
          moved_off += !Near(got, want, 15.0);  // three steps move a vertex less than an edge (4 to 12 m)
        } else {
          moved_off += !Near(got, reference[c], float32 ? Step(got - offset) : 0.0);
        }
      }
      if (output == "ref.obj") reference = out_corners;
      EXPECT_EQ(unmoved_off, 0) << "vertices the job keeps, not as they went in";
      EXPECT_EQ(moved_off, 0) << "vertices the job moves, not where the .obj output has them";
      if (!input.gltf) {
        EXPECT_GT(moved, 0) << "the job moved nothing";
      }
      // Attributes: kept where the output holds them, named where it does not.
      if (!v.attributes) continue;
      if (input.gltf) {  // the file's own texture coordinates, bit for bit
        absl::StatusOr<TexcoordOriginals> in_uv = ReadTexcoordOriginals((dir / input.name).string());
        absl::StatusOr<TexcoordOriginals> out_uv = ReadTexcoordOriginals((dir / output).string());
        ASSERT_TRUE(in_uv.ok() && out_uv.ok());
        int64_t rounded = 0;  // the input's values that Draco's round trip changes
        for (const auto& [trip, original] : in_uv->original_of) rounded += trip != original;
        EXPECT_GT(rounded, 50);
        EXPECT_TRUE(in_uv->original_of == out_uv->original_of) << "texture coordinates changed";
        continue;
      }
      const bool holds_uv = output != "out.off" && output != "out.stl";
      const bool holds_properties = output == "out.ply" || output == "out.drc";
      const bool had_properties = !truth.properties.empty();
      EXPECT_EQ(!out.uvs.empty() || out_uvs, holds_uv);
      EXPECT_EQ(!out.colors.empty() || out_colors, holds_uv);
      if (holds_uv && !out.uvs.empty()) {
        int64_t uv_off = 0;
        for (size_t t = 0; t < out.triangles.size(); ++t) {
          for (int k = 0; k < 3; ++k) {
            const int32_t a = truth.uvs.corners[3 * t + k], b = out.uvs.corners[3 * t + k];
            uv_off += truth.uvs.values[2 * a] != out.uvs.values[2 * b] ||
                      truth.uvs.values[2 * a + 1] != out.uvs.values[2 * b + 1];
          }
        }
        EXPECT_EQ(uv_off, 0) << "texture coordinates changed";
      }
      EXPECT_EQ(absl::StrContains(run.err, "texture coordinates"), !holds_uv) << run.err;
      EXPECT_EQ(absl::StrContains(run.json, "texture coordinates"), !holds_uv) << run.json;
      EXPECT_EQ(absl::StrContains(run.err, "vertex properties confidence"), had_properties && !holds_properties)
          << run.err;
      if (had_properties && holds_properties) {
        ASSERT_EQ(out.properties.size(), 1u);
        EXPECT_EQ(out.properties[0].values.size(), out.positions.size());
      }
    }
  }
  fs::remove_all(root);
}

// Two .gltf outputs in one folder, the input's: each reads back as its own mesh, the input as
// it was.
TEST_F(IoMatrixTest, TwoGltfOutputsInOneFolderKeepTheirOwnMeshes) {
  ASSERT_FALSE(daemon_->target().empty()) << "meshsmoothd did not start";
  const fs::path dir = fs::temp_directory_path() / absl::StrCat("meshsmooth_io_two_gltf_", getpid()) / "scans";
  fs::create_directories(dir);
  const Variant v{false, true};
  const Mesh patch = Patch(v);
  UseDracoFileIo();
  ASSERT_TRUE(draco::WriteSceneToFile((dir / "in.gltf").string(), *PatchScene(patch, v)).ok());
  const std::map<std::string, std::string> inputs = Snapshot(dir);
  ASSERT_EQ(Smooth(daemon_->target(), dir, "in.gltf", "a.gltf", "--flow laplacian --iterations 1").exit_code, 0);
  ASSERT_EQ(Smooth(daemon_->target(), dir, "in.gltf", "b.gltf", "--flow laplacian --iterations 8").exit_code, 0);
  // Smoothing the input's own folder's output once more over it leaves the input as it was.
  ASSERT_EQ(Smooth(daemon_->target(), dir, "in.gltf", "b.gltf", "--flow laplacian --iterations 8").exit_code, 0);
  const std::map<std::string, std::string> after = Snapshot(dir);
  for (const auto& [name, bytes] : inputs) {
    ASSERT_TRUE(after.count(name)) << name;
    EXPECT_TRUE(after.at(name) == bytes) << "changed " << name;
  }
  absl::StatusOr<GltfScene> in = GltfScene::Read((dir / "in.gltf").string());
  absl::StatusOr<GltfScene> a = GltfScene::Read((dir / "a.gltf").string());
  absl::StatusOr<GltfScene> b = GltfScene::Read((dir / "b.gltf").string());
  ASSERT_TRUE(in.ok() && a.ok() && b.ok());
  // One iteration moves less than eight: a and b are not one mesh.
  double moved_a = 0.0, moved_b = 0.0;
  for (size_t i = 0; i < in->surface().positions.size(); ++i) {
    moved_a += Norm(a->surface().positions[i] - in->surface().positions[i]);
    moved_b += Norm(b->surface().positions[i] - in->surface().positions[i]);
  }
  EXPECT_GT(moved_a, 0.0);
  EXPECT_GT(moved_b, 2.0 * moved_a);
  fs::remove_all(dir.parent_path());
}

// The output's folder and format are checked before anything is sent: with no server to send
// to, a bad -o is still a bad command line (2), not an unreachable server (3).
TEST(IoPathTest, OutputPathIsCheckedBeforeTheUpload) {
  const fs::path dir = fs::temp_directory_path() / absl::StrCat("meshsmooth_io_path_", getpid());
  fs::create_directories(dir / "folder.ply");
  ASSERT_TRUE(WriteMesh((dir / "in.obj").string(), Patch({false, false})).ok());
  const std::string nowhere = "127.0.0.1:1";  // nothing listens there
  CliRun r = Smooth(nowhere, dir, "in.obj", "no-such-folder/out.ply");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_TRUE(absl::StrContains(r.err, "no folder")) << r.err;
  r = Smooth(nowhere, dir, "in.obj", "folder.ply");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_TRUE(absl::StrContains(r.err, "a folder, not a file")) << r.err;
  r = Smooth(nowhere, dir, "in.obj", "out.ply");  // a fine output: now the server is missed
  EXPECT_EQ(r.exit_code, 3) << r.err;
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Variants, IoMatrixTest,
                         ::testing::Values(Variant{false, false}, Variant{true, false}, Variant{false, true},
                                           Variant{true, true}),
                         [](const ::testing::TestParamInfo<Variant>& param) {
                           return absl::StrCat(param.param.georeferenced ? "Georeferenced" : "AtOrigin",
                                               param.param.attributes ? "WithAttributes" : "Plain");
                         });

}  // namespace
}  // namespace meshsmooth::testing
