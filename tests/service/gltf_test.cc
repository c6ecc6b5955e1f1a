// glTF scenes through the CLI's upload and write-back (client/transfer.h) and the service: a
// noisy textured sphere with UV seams in two primitives that share their border positions, in
// a node whose translation holds survey coordinates, as plain and Draco-compressed GLB, written
// as GLB and as glTF: the same nodes, primitives, materials, textures and images, the same
// texture coordinates and seams, fresh normals, the translation kept, positions nearer the
// sphere than the noisy input's, and no crack between the primitives.
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "client/transfer.h"
#include "core/io/crash_report.h"
#include "core/io/draco_codec.h"
#include "core/io/file_bytes.h"
#include "core/io/gltf.h"
#include "core/render/image.h"
#include "core/render/png.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "draco/io/scene_io.h"
#include "draco/scene/scene.h"
#include "gtest/gtest.h"
#include "tests/gltf_fixtures.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth::testing {
namespace {

namespace fs = std::filesystem;

const Eigen::Vector3d kSurvey(512345.0, 5412345.0, 231.0);

// The longitude of unit vector u as a texture coordinate in [0, 1).
float Longitude(const Vec3& u) { return static_cast<float>(0.5 + std::atan2(u.y, u.x) / (2 * M_PI)); }

// The primitive of `sphere`'s triangles for which `keep` holds: its own points (the vertices its
// triangles use, in order of first use), lat-long texture coordinates and unit normals. A face
// across the date line takes its western corners as points of their own whose longitude
// coordinate is past 1: a UV seam, one position with two texture coordinates.
template <typename Keep>
std::unique_ptr<draco::Mesh> Primitive(const Mesh& sphere, const Keep& keep) {
  std::map<std::pair<int32_t, bool>, uint32_t> point_of;  // (vertex, past 1)
  std::vector<std::pair<int32_t, bool>> vertex_of;
  std::vector<std::array<uint32_t, 3>> faces;
  for (const Triangle& t : sphere.triangles) {
    if (!keep(t)) continue;
    float lo = 1.0f, hi = 0.0f;
    for (int32_t v : t) {
      lo = std::min(lo, Longitude(Normalized(sphere.positions[v])));
      hi = std::max(hi, Longitude(Normalized(sphere.positions[v])));
    }
    std::array<uint32_t, 3> f;
    for (int k = 0; k < 3; ++k) {
      const bool past = hi - lo > 0.5f && Longitude(Normalized(sphere.positions[t[k]])) < 0.5f;
      auto [it, fresh] = point_of.try_emplace({t[k], past}, static_cast<uint32_t>(vertex_of.size()));
      if (fresh) vertex_of.push_back({t[k], past});
      f[k] = it->second;
    }
    faces.push_back(f);
  }
  auto dm = std::make_unique<draco::Mesh>();
  const uint32_t n = static_cast<uint32_t>(vertex_of.size());
  dm->set_num_points(n);
  auto add = [&](draco::GeometryAttribute::Type type, int components) {
    return AddFloatAttribute(*dm, type, components, n);
  };
  draco::PointAttribute* pos = add(draco::GeometryAttribute::POSITION, 3);
  draco::PointAttribute* uv = add(draco::GeometryAttribute::TEX_COORD, 2);
  draco::PointAttribute* nrm = add(draco::GeometryAttribute::NORMAL, 3);
  for (uint32_t p = 0; p < n; ++p) {
    const Vec3& q = sphere.positions[vertex_of[p].first];
    const float xyz[3] = {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
    pos->SetAttributeValue(draco::AttributeValueIndex(p), xyz);
    const Vec3 u = Normalized(q);
    const float st[2] = {Longitude(u) + (vertex_of[p].second ? 1.0f : 0.0f), static_cast<float>(std::acos(u.z) / M_PI)};
    uv->SetAttributeValue(draco::AttributeValueIndex(p), st);
    const float nn[3] = {static_cast<float>(u.x), static_cast<float>(u.y), static_cast<float>(u.z)};
    nrm->SetAttributeValue(draco::AttributeValueIndex(p), nn);
  }
  for (const auto& f : faces) {
    dm->AddFace({draco::PointIndex(f[0]), draco::PointIndex(f[1]), draco::PointIndex(f[2])});
  }
  return dm;
}

// Per primitive: how many of its points share their position with another point of it that
// has other texture coordinates (UV seams), and the largest angle (degrees) between a point's
// normal and the area-weighted normal of the primitive's faces at its position.
struct SeamsAndNormals {
  int64_t seam_points = 0;
  double worst_normal_deg = 0.0;
};
SeamsAndNormals MeasureSeamsAndNormals(const draco::Scene& s) {
  SeamsAndNormals out;
  for (int m = 0; m < s.NumMeshes(); ++m) {
    const draco::Mesh& dm = s.GetMesh(draco::MeshIndex(m));
    const draco::PointAttribute* pos = dm.GetNamedAttribute(draco::GeometryAttribute::POSITION);
    const draco::PointAttribute* uv = dm.GetNamedAttribute(draco::GeometryAttribute::TEX_COORD);
    const draco::PointAttribute* nrm = dm.GetNamedAttribute(draco::GeometryAttribute::NORMAL);
    auto position = [&](draco::PointIndex p) {
      std::array<float, 3> q;
      pos->GetMappedValue(p, q.data());
      return q;
    };
    std::map<std::array<float, 3>, std::set<std::array<float, 2>>> uvs_at;
    for (uint32_t p = 0; p < dm.num_points(); ++p) {
      std::array<float, 2> st;
      uv->GetMappedValue(draco::PointIndex(p), st.data());
      uvs_at[position(draco::PointIndex(p))].insert(st);
    }
    std::map<std::array<float, 3>, Vec3> normal_at;
    for (uint32_t f = 0; f < dm.num_faces(); ++f) {
      const draco::Mesh::Face& face = dm.face(draco::FaceIndex(f));
      Vec3 c[3];
      for (int k = 0; k < 3; ++k) {
        const std::array<float, 3> q = position(face[k]);
        c[k] = {q[0], q[1], q[2]};
      }
      for (int k = 0; k < 3; ++k) normal_at[position(face[k])] += Cross(c[1] - c[0], c[2] - c[0]);
    }
    for (uint32_t p = 0; p < dm.num_points(); ++p) {
      const std::array<float, 3> q = position(draco::PointIndex(p));
      out.seam_points += uvs_at[q].size() > 1;
      float n[3];
      nrm->GetMappedValue(draco::PointIndex(p), n);
      const double cosine = Dot(Normalized(normal_at[q]), Vec3{n[0], n[1], n[2]});
      out.worst_normal_deg = std::max(out.worst_normal_deg, std::acos(std::min(1.0, cosine)) * 180.0 / M_PI);
    }
  }
  return out;
}

// The scene: one node translated to survey coordinates, one glTF mesh of two primitives (the
// northern and the southern faces) with a material each, the first with a PNG texture.
std::unique_ptr<draco::Scene> SphereScene(const Mesh& noisy, const std::string& png) {
  auto scene = std::make_unique<draco::Scene>();
  auto north = [&](const Triangle& t) {
    return noisy.positions[t[0]].z + noisy.positions[t[1]].z + noisy.positions[t[2]].z > 0;
  };
  const draco::MeshIndex a = scene->AddMesh(Primitive(noisy, north));
  const draco::MeshIndex b = scene->AddMesh(Primitive(noisy, [&](const Triangle& t) { return !north(t); }));
  draco::MaterialLibrary& materials = scene->GetMaterialLibrary();
  auto texture = std::make_unique<draco::Texture>();
  texture->source_image().MutableEncodedData().assign(png.begin(), png.end());
  texture->source_image().set_mime_type("image/png");
  const int t = materials.MutableTextureLibrary().PushTexture(std::move(texture));
  draco::Material* skin = materials.MutableMaterial(0);
  skin->SetName("skin");
  EXPECT_TRUE(skin->SetTextureMap(materials.MutableTextureLibrary().GetTexture(t), draco::TextureMap::COLOR, 0).ok());
  materials.MutableMaterial(1)->SetName("bark");
  const draco::MeshGroupIndex g = scene->AddMeshGroup();
  scene->GetMeshGroup(g)->AddMeshInstance({a, 0});
  scene->GetMeshGroup(g)->AddMeshInstance({b, 1});
  const draco::SceneNodeIndex node = scene->AddNode();
  scene->GetNode(node)->SetMeshGroupIndex(g);
  draco::TrsMatrix trs;
  trs.SetTranslation(kSurvey);
  scene->GetNode(node)->SetTrsMatrix(trs);
  scene->AddRootNodeIndex(node);
  return scene;
}

// The RMS of |p| - 1 over the points of every primitive.
double RmsToSphere(const draco::Scene& s) {
  double sum = 0.0;
  int64_t n = 0;
  for (int m = 0; m < s.NumMeshes(); ++m) {
    const draco::Mesh& dm = s.GetMesh(draco::MeshIndex(m));
    const draco::PointAttribute* pos = dm.GetNamedAttribute(draco::GeometryAttribute::POSITION);
    for (uint32_t p = 0; p < dm.num_points(); ++p) {
      float q[3];
      pos->GetMappedValue(draco::PointIndex(p), q);
      const double d = std::sqrt(double{q[0]} * q[0] + double{q[1]} * q[1] + double{q[2]} * q[2]) - 1.0;
      sum += d * d;
      ++n;
    }
  }
  return std::sqrt(sum / n);
}

// Every point's value of the attribute `type`, primitive after primitive.
std::vector<float> Values(const draco::Scene& s, draco::GeometryAttribute::Type type, int components) {
  std::vector<float> out;
  for (int m = 0; m < s.NumMeshes(); ++m) {
    const draco::Mesh& dm = s.GetMesh(draco::MeshIndex(m));
    const draco::PointAttribute* a = dm.GetNamedAttribute(type);
    if (a == nullptr) continue;
    for (uint32_t p = 0; p < dm.num_points(); ++p) {
      float v[4];
      a->GetMappedValue(draco::PointIndex(p), v);
      out.insert(out.end(), v, v + components);
    }
  }
  return out;
}

std::unique_ptr<draco::Scene> ReadScene(const std::string& path) {
  UseDracoFileIo();
  auto s = draco::ReadSceneFromFile(path);
  EXPECT_TRUE(s.ok()) << path << ": " << s.status().error_msg();
  return s.ok() ? std::move(s).value() : nullptr;
}

TEST(GltfTest, ScenesComeBackWithTheirNodesMaterialsTexturesAndUvs) {
  std::unique_ptr<server::Server> server = StartServer();
  ASSERT_NE(server, nullptr);
  const fs::path dir = fs::temp_directory_path() /
                       ("meshsmooth_gltf_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  fs::create_directories(dir);
  Image image;
  image.width = image.height = 16;
  image.rgb.assign(3 * 16 * 16, 0);
  for (size_t i = 0; i < image.rgb.size(); i += 3) image.rgb[i] = static_cast<uint8_t>(i);
  absl::StatusOr<std::string> png = EncodePng(image);
  ASSERT_TRUE(png.ok());
  Mesh noisy = Icosphere(4);
  AddUniformNoise(noisy, 0.3, 3);
  const std::unique_ptr<draco::Scene> scene = SphereScene(noisy, *png);
  const std::string plain = (dir / "plain.glb").string(), packed = (dir / "draco.glb").string();
  UseDracoFileIo();
  ASSERT_TRUE(draco::WriteSceneToFile(plain, *scene).ok());
  for (int m = 0; m < scene->NumMeshes(); ++m) scene->GetMesh(draco::MeshIndex(m)).SetCompressionEnabled(true);
  ASSERT_TRUE(draco::WriteSceneToFile(packed, *scene).ok());

  for (const std::string& input : {plain, packed}) {
    for (const char* name : {"out.glb", "gltf/out.gltf", "out-draco.glb"}) {
      const bool draco_out = std::string(name) == "out-draco.glb";
      SCOPED_TRACE(input + " -> " + name);
      const std::string output = (dir / name).string();
      fs::create_directories(fs::path(output).parent_path());
      const std::unique_ptr<draco::Scene> in = ReadScene(input);
      ASSERT_NE(in, nullptr);
      absl::StatusOr<client::Upload> upload = client::PrepareUpload(input);
      ASSERT_TRUE(upload.ok()) << upload.status();
      absl::StatusOr<SmoothOutcome> outcome = Call(server->InProcessChannel(), v1::JobSpec(), upload->draco);
      ASSERT_TRUE(outcome.ok()) << outcome.status();
      std::vector<std::string> dropped;
      ASSERT_TRUE(client::WriteResult(*upload, outcome->result, output, false, &dropped, draco_out).ok());
      EXPECT_TRUE(dropped.empty());
      const std::unique_ptr<draco::Scene> out = ReadScene(output);
      ASSERT_NE(out, nullptr);
      absl::StatusOr<GltfScene> in_scene = GltfScene::Read(input), out_scene = GltfScene::Read(output);
      ASSERT_TRUE(in_scene.ok() && out_scene.ok());
      EXPECT_EQ(out_scene->counts(), in_scene->counts());
      EXPECT_EQ(out_scene->counts(), (GltfCounts{1, 1, 2, 2, 1}));
      if (fs::path(output).extension() == ".gltf") {  // its image written beside it, and named in it
        const absl::StatusOr<std::string> json = ReadFileBytes(output);
        ASSERT_TRUE(json.ok());
        int images = 0;
        for (const fs::directory_entry& e : fs::directory_iterator(fs::path(output).parent_path())) {
          if (e.path().extension() != ".png") continue;
          ++images;
          EXPECT_NE(json->find("\"" + e.path().filename().string() + "\""), std::string::npos);
        }
        EXPECT_EQ(images, 1);
      }
      const auto translation = out->GetNode(draco::SceneNodeIndex(0))->GetTrsMatrix().Translation();
      ASSERT_TRUE(translation.ok());
      EXPECT_EQ(translation.value(), kSurvey);
      const double before = RmsToSphere(*in), after = RmsToSphere(*out);
      EXPECT_LT(after, 0.5 * before) << "RMS distance to the sphere " << before << " -> " << after;
      // Draco's own transcoder opens it.
      if (fs::exists("/usr/bin/draco_transcoder")) {
        const std::string again = (dir / "transcoded.glb").string();
        const std::string command = "/usr/bin/draco_transcoder -i '" + output + "' -o '" + again + "' >/dev/null 2>&1";
        EXPECT_EQ(std::system(command.c_str()), 0);
      }
      // Draco-compressed output reorders each primitive's points and quantizes it on a grid of
      // its own: nothing more to compare point by point.
      if (draco_out) continue;
      EXPECT_EQ(Values(*out, draco::GeometryAttribute::TEX_COORD, 2),
                Values(*in, draco::GeometryAttribute::TEX_COORD, 2));
      // No crack: points at one position in the input are at one position in the output.
      const std::vector<float> in_pos = Values(*in, draco::GeometryAttribute::POSITION, 3);
      const std::vector<float> out_pos = Values(*out, draco::GeometryAttribute::POSITION, 3);
      ASSERT_EQ(in_pos.size(), out_pos.size());
      std::map<std::array<float, 3>, std::array<float, 3>> moved;
      int64_t cracks = 0, shared = 0;
      for (size_t i = 0; i < in_pos.size(); i += 3) {
        auto [it, fresh] = moved.try_emplace({in_pos[i], in_pos[i + 1], in_pos[i + 2]},
                                             std::array<float, 3>{out_pos[i], out_pos[i + 1], out_pos[i + 2]});
        if (fresh) continue;
        ++shared;
        cracks += it->second != std::array<float, 3>{out_pos[i], out_pos[i + 1], out_pos[i + 2]};
      }
      // Draco's glTF compression quantizes each primitive on a grid of its own, so the border
      // points of the compressed input already differ by up to a grid step: none shared there.
      if (input == plain) {
        EXPECT_GT(shared, 0);
      }
      EXPECT_EQ(cracks, 0);
      // Normals: unit, and fresh: each point's is the area-weighted normal of its primitive's
      // faces at its position in the output, the same on both sides of a UV seam (the input's
      // point along the noisy input's radius, more than 10 degrees off somewhere).
      const std::vector<float> normals = Values(*out, draco::GeometryAttribute::NORMAL, 3);
      ASSERT_EQ(normals.size(), out_pos.size());
      for (size_t i = 0; i < normals.size(); i += 3) {
        EXPECT_NEAR(std::hypot(normals[i], normals[i + 1], normals[i + 2]), 1.0, 1e-5);
      }
      const SeamsAndNormals before_seams = MeasureSeamsAndNormals(*in), after_seams = MeasureSeamsAndNormals(*out);
      EXPECT_GT(before_seams.seam_points, 20);                       // the input has UV seams...
      EXPECT_EQ(after_seams.seam_points, before_seams.seam_points);  // ...and keeps them
      EXPECT_GT(before_seams.worst_normal_deg, 10.0);
      EXPECT_LT(after_seams.worst_normal_deg, 0.05);  // float rounding
    }
  }
  fs::remove_all(dir);
}

// A Draco-compressed GLB whose "buffers" key is misspelt (as fuzz_gltf found it): Draco's own glTF
// reader dereferences a null pointer on it. The CLI reads a glTF file in a child process first,
// so the upload is refused with a message instead of the CLI crashing, and the child's stack
// tells that the crash was Draco's.
TEST(GltfTest, FileThatCrashesDracosReaderIsRefused) {
  const fs::path dir = fs::temp_directory_path() / ("meshsmooth_gltf_crash_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const absl::StatusOr<std::string> png = GreyPng();
  ASSERT_TRUE(png.ok());
  const std::unique_ptr<draco::Scene> scene = SphereScene(Icosphere(2), *png);
  for (int m = 0; m < scene->NumMeshes(); ++m) scene->GetMesh(draco::MeshIndex(m)).SetCompressionEnabled(true);
  const std::string packed = (dir / "draco.glb").string(), broken = (dir / "broken.glb").string();
  UseDracoFileIo();
  ASSERT_TRUE(draco::WriteSceneToFile(packed, *scene).ok());
  absl::StatusOr<std::string> bytes = ReadFileBytes(packed);
  ASSERT_TRUE(bytes.ok());
  const size_t at = bytes->find("\"buffers\"");
  ASSERT_NE(at, std::string::npos);
  bytes->replace(at, 9, "\"bufferm\"");  // the same length: the GLB's chunk sizes still hold
  ASSERT_TRUE(WriteFileBytes(broken, *bytes).ok());
  ASSERT_TRUE(client::PrepareUpload(packed).ok());
  const absl::StatusOr<client::Upload> upload = client::PrepareUpload(broken);
  fs::remove_all(dir);
  ASSERT_FALSE(upload.ok());
  EXPECT_EQ(upload.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(upload.status().message().find("Draco's glTF reader crashed on it (SEGV in tinygltf::"), std::string::npos)
      << upload.status();
  EXPECT_TRUE(upload.status().GetPayload(kCrashReportPayload).has_value());
}

// Positions that no reader would take back (not finite, or beyond kMaxCoordinate, which float32
// holds exactly) are refused by the writer, as the Draco encoder refuses them, rather than
// written (fuzz_gltf: a NaN read from a file was written into a GLB that did not read again).
TEST(GltfTest, WriterRefusesPositionsNoReaderTakes) {
  const fs::path dir = fs::temp_directory_path() / ("meshsmooth_gltf_nan_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const absl::StatusOr<std::string> png = GreyPng();
  ASSERT_TRUE(png.ok());
  const std::string in = (dir / "in.glb").string(), out = (dir / "out.glb").string();
  UseDracoFileIo();
  ASSERT_TRUE(draco::WriteSceneToFile(in, *SphereScene(Icosphere(2), *png)).ok());
  absl::StatusOr<GltfScene> scene = GltfScene::Read(in);
  ASSERT_TRUE(scene.ok()) << scene.status();
  std::vector<Vec3> positions = scene->surface().positions;
  ASSERT_TRUE(scene->Write(positions, out, false).ok());
  for (double bad : {std::nan(""), 2 * kMaxCoordinate}) {
    positions[5].y = bad;
    const absl::Status s = scene->Write(positions, out, false);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(s.message().find("vertex 5 has a coordinate of"), std::string::npos) << s;
  }
  fs::remove_all(dir);
}

// A valid glTF document without a mesh (only its asset), as GLB: refused with a message, not
// read past the end of an empty list of meshes.
TEST(GltfTest, SceneWithoutMeshesIsRefused) {
  std::string json = R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[]}],"scene":0})";
  json.resize((json.size() + 3) / 4 * 4, ' ');
  auto le32 = [](uint32_t v) { return std::string{char(v), char(v >> 8), char(v >> 16), char(v >> 24)}; };
  const std::string glb = "glTF" + le32(2) + le32(12 + 8 + json.size()) + le32(json.size()) + "JSON" + json;
  const fs::path path = fs::temp_directory_path() / ("meshsmooth_empty_" + std::to_string(getpid()) + ".glb");
  ASSERT_TRUE(WriteFileBytes(path.string(), glb).ok());
  const absl::StatusOr<GltfScene> scene = GltfScene::Read(path.string());
  fs::remove(path);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(scene.status().message().find("no triangles"), std::string::npos) << scene.status();
}

}  // namespace
}  // namespace meshsmooth::testing
