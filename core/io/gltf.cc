#include "core/io/gltf.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/io/crash_report.h"
#include "core/io/draco_checks.h"
#include "core/io/draco_codec.h"
#include "core/io/file_bytes.h"
#include "core/io/gltf_texcoords.h"
#include "draco/io/file_reader_factory.h"
#include "draco/io/file_utils.h"
#include "draco/io/file_writer_factory.h"
#include "draco/io/gltf_encoder.h"
#include "draco/io/scene_io.h"
#include "draco/io/stdio_file_reader.h"
#include "draco/io/stdio_file_writer.h"
#include "draco/scene/scene.h"
#include "draco/scene/scene_utils.h"
#include "draco/texture/texture_utils.h"

namespace meshsmooth {

struct GltfScene::Impl {
  std::unique_ptr<draco::Scene> scene;
  Mesh surface;
  // Per scene mesh (primitive): its first vertex in surface and the offset it was moved by.
  std::vector<int32_t> first;
  std::vector<Vec3> offset;
  // The scene's images and the names they were read under (SceneImages).
  std::vector<std::pair<draco::Texture*, std::string>> images;
  // The input file's texture coordinates, written back over Draco's round trip of them; empty
  // when the file's own JSON could not be followed (stale() says so).
  std::optional<TexcoordOriginals> texcoords;
};

namespace {

// Every image of `scene`, material or not, with the name it is written under: its stem as read
// ("image<i>" when it had none).
std::vector<std::pair<draco::Texture*, std::string>> SceneImages(draco::Scene& scene) {
  std::vector<std::pair<draco::Texture*, std::string>> images;
  for (draco::TextureLibrary* library :
       {&scene.GetMaterialLibrary().MutableTextureLibrary(), &scene.GetNonMaterialTextureLibrary()}) {
    for (size_t t = 0; t < library->NumTextures(); ++t) {
      draco::Texture* texture = library->GetTexture(static_cast<int>(t));
      const std::string stem = draco::TextureUtils::GetTargetStem(*texture);
      images.emplace_back(texture, stem.empty() ? absl::StrCat("image", images.size()) : stem);
    }
  }
  return images;
}

// Writes `scene` to `path` with every file beside it named after it: a .gltf's buffer as
// STEM.bin and its images as STEM_IMAGE.EXT, IMAGE the name each image was read under (Draco's
// own WriteSceneToFile names the buffer buffer0.bin and the images by their bare names, so a
// scene written to a folder replaced the files of another scene there, the input's own
// included). A .glb holds everything itself.
absl::Status WriteNamedAfter(draco::Scene& scene, const std::vector<std::pair<draco::Texture*, std::string>>& images,
                             const std::string& path) {
  const std::filesystem::path out(path);
  const std::string dir = out.has_parent_path() ? out.parent_path().string() : std::string(".");
  const std::string stem = out.stem().string();
  for (const auto& [texture, name] : images) {
    draco::SourceImage& image = texture->source_image();
    // An image not yet read goes from its bytes, not from the file its new name would name.
    if (image.encoded_data().empty() && !image.filename().empty()) {
      std::vector<uint8_t> bytes;
      if (!draco::ReadFileToBuffer(image.filename(), &bytes)) {
        return absl::NotFoundError(absl::StrCat("the scene's image ", image.filename(), " cannot be read"));
      }
      image.MutableEncodedData() = std::move(bytes);
    }
    image.set_filename(absl::StrCat(dir, "/", stem, "_", name, ".", draco::TextureUtils::GetTargetExtension(*texture)));
  }
  draco::GltfEncoder encoder;
  const draco::Status s = encoder.EncodeFile(scene, path, absl::StrCat(dir, "/", stem, ".bin"), dir);
  if (!s.ok()) return absl::InternalError(absl::StrCat("writing ", path, ": ", s.error_msg()));
  return absl::OkStatus();
}

}  // namespace

GltfScene::GltfScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GltfScene::GltfScene(GltfScene&&) noexcept = default;
GltfScene& GltfScene::operator=(GltfScene&&) noexcept = default;
GltfScene::~GltfScene() = default;

void UseDracoFileIo() {
  static const bool registered = [] {
    draco::FileReaderFactory::RegisterReader(draco::StdioFileReader::Open);
    draco::FileWriterFactory::RegisterWriter(draco::StdioFileWriter::Open);
    return true;
  }();
  (void)registered;
}

absl::StatusOr<GltfScene> GltfScene::Read(const std::string& path) {
  UseDracoFileIo();
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    return absl::NotFoundError(absl::StrCat(path, ": no such file"));
  }
  // Through Draco's own entry point, never a GltfDecoder of ours: the class holds a
  // tinygltf::Model, whose layout in Debian's libtinygltf-dev differs from the one libdraco
  // was built with (docs/decisions.md).
  draco::StatusOr<std::unique_ptr<draco::Scene>> decoded = draco::ReadSceneFromFile(path);
  if (!decoded.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not a glTF scene Draco reads: ", decoded.status().error_msg()));
  }
  auto impl = std::make_unique<Impl>();
  impl->scene = std::move(decoded).value();
  draco::Scene& scene = *impl->scene;
  impl->images = SceneImages(scene);
  if (absl::StatusOr<TexcoordOriginals> t = ReadTexcoordOriginals(path); t.ok()) impl->texcoords = std::move(*t);
  const int n = scene.NumMeshes();
  if (n == 0) return absl::InvalidArgumentError(absl::StrCat(path, ": the glTF scene has no triangles"));
  // Each primitive's glTF mesh (mesh group): the first that names it.
  std::vector<int> group_of(n, -1);
  for (int g = 0; g < scene.NumMeshGroups(); ++g) {
    const draco::MeshGroup& group = *scene.GetMeshGroup(draco::MeshGroupIndex(g));
    for (int i = 0; i < group.NumMeshInstances(); ++i) {
      const int m = group.GetMeshInstance(i).mesh_index.value();
      if (m >= 0 && m < n && group_of[m] < 0) group_of[m] = g;
    }
  }
  for (int m = 0, next = scene.NumMeshGroups(); m < n; ++m) {
    if (group_of[m] < 0) group_of[m] = next++;
  }
  // The positions of every primitive, and each glTF mesh's bounding box.
  std::vector<std::vector<Vec3>> points(n);
  std::vector<BoundingBox> boxes(*std::max_element(group_of.begin(), group_of.end()) + 1);
  double widest = 0.0;
  for (int m = 0; m < n; ++m) {
    const draco::Mesh& dm = scene.GetMesh(draco::MeshIndex(m));
    const draco::PointAttribute* pos = dm.GetNamedAttribute(draco::GeometryAttribute::POSITION);
    if (pos == nullptr) continue;
    points[m].resize(dm.num_points());
    for (uint32_t p = 0; p < dm.num_points(); ++p) {
      double xyz[3] = {0, 0, 0};
      const draco::AttributeValueIndex avi = pos->mapped_index(draco::PointIndex(p));
      if (avi.value() >= pos->size()) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": glTF primitive ", m, " has a point without a position"));
      }
      pos->ConvertValue<double>(avi, 3, xyz);
      points[m][p] = {xyz[0], xyz[1], xyz[2]};
      boxes[group_of[m]].Add(points[m][p]);
    }
  }
  for (const BoundingBox& b : boxes) widest = std::max(widest, b.max_extent());
  std::vector<double> shift(boxes.size(), 0.0);
  double start = boxes.empty() || boxes[0].empty() ? 0.0 : boxes[0].hi.x;
  for (size_t g = 1; g < boxes.size(); ++g) {
    if (boxes[g].empty()) continue;
    // Whole units past the previous mesh, so the shift itself is exact.
    shift[g] = std::ceil(start + widest + 1.0 - boxes[g].lo.x);
    start = boxes[g].hi.x + shift[g];
  }
  Mesh& s = impl->surface;
  for (int m = 0; m < n; ++m) {
    const draco::Mesh& dm = scene.GetMesh(draco::MeshIndex(m));
    const int32_t first = s.num_vertices();
    const Vec3 offset{shift[group_of[m]], 0.0, 0.0};
    impl->first.push_back(first);
    impl->offset.push_back(offset);
    for (const Vec3& p : points[m]) s.positions.push_back(p + offset);
    if (points[m].empty()) continue;
    for (uint32_t f = 0; f < dm.num_faces(); ++f) {
      const draco::Mesh::Face& face = dm.face(draco::FaceIndex(f));
      if (face[0].value() >= dm.num_points() || face[1].value() >= dm.num_points() ||
          face[2].value() >= dm.num_points()) {
        return absl::InvalidArgumentError(absl::StrCat(path, ": glTF primitive ", m, " has a face past its points"));
      }
      s.triangles.push_back({first + static_cast<int32_t>(face[0].value()),
                             first + static_cast<int32_t>(face[1].value()),
                             first + static_cast<int32_t>(face[2].value())});
    }
  }
  if (s.triangles.empty()) return absl::InvalidArgumentError(absl::StrCat(path, ": the glTF scene has no triangles"));
  return GltfScene(std::move(impl));
}

absl::Status WriteMeshAsGltf(std::string_view bytes, const Vec3& origin, const std::string& path, bool draco_compressed,
                             std::vector<std::string>* dropped) {
  absl::StatusOr<std::unique_ptr<draco::Mesh>> mesh = DecodeDracoMesh(bytes);
  if (!mesh.ok()) return absl::InvalidArgumentError(absl::StrCat("the result: ", mesh.status().message()));
  std::unique_ptr<draco::Mesh> m = std::move(*mesh);
  std::vector<std::string> names;
  for (int a = m->num_attributes() - 1; a >= 0; --a) {
    if (m->attribute(a)->attribute_type() != draco::GeometryAttribute::GENERIC) continue;
    const draco::AttributeMetadata* meta = m->GetAttributeMetadataByAttributeId(a);
    std::string name;
    if (meta == nullptr || !meta->GetEntryString("name", &name)) name = absl::StrCat("attribute ", a);
    names.insert(names.begin(), name);
    m->DeleteAttribute(a);
  }
  if (!names.empty() && dropped != nullptr) {
    dropped->push_back(absl::StrCat("vertex properties ", absl::StrJoin(names, ", "), " (glTF has no place for them)"));
  }
  draco::StatusOr<std::unique_ptr<draco::Scene>> made = draco::SceneUtils::MeshToScene(std::move(m));
  if (!made.ok()) return absl::InternalError(absl::StrCat("writing ", path, ": ", made.status().error_msg()));
  std::unique_ptr<draco::Scene> scene = std::move(made).value();
  if (origin != Vec3{}) {
    for (int n = 0; n < scene->NumRootNodes(); ++n) {
      draco::TrsMatrix trs;
      trs.SetTranslation(Eigen::Vector3d(origin.x, origin.y, origin.z));
      scene->GetNode(scene->GetRootNodeIndex(n))->SetTrsMatrix(trs);
    }
  }
  if (draco_compressed) {
    draco::DracoCompressionOptions options;
    options.quantization_position.SetQuantizationBits(16);
    options.quantization_bits_tex_coord = 16;
    options.quantization_bits_normal = 12;
    draco::SceneUtils::SetDracoCompressionOptions(&options, scene.get());
  }
  UseDracoFileIo();
  return WriteNamedAfter(*scene, SceneImages(*scene), path);
}

namespace {

// What the child of ReadInChildFirst writes first to its pipe once it has read the scene; a crash
// report may follow.
constexpr std::string_view kSceneRead = "the scene was read\n";

// The child of ReadInChildFirst: reads `path` and writes the scene it reads to a temporary .glb,
// plain and (with `draco_compressed`) Draco-compressed. `fd` gets kSceneRead once the scene is
// read, and the crash report if one of the steps crashes.
[[noreturn]] void ReadAndWriteInChild(const std::string& path, bool draco_compressed, int fd) {
  SendCrashReportsTo(fd);
  absl::StatusOr<GltfScene> scene = GltfScene::Read(path);
  if (!scene.ok()) _exit(0);
  if (write(fd, kSceneRead.data(), kSceneRead.size()) != static_cast<ssize_t>(kSceneRead.size())) _exit(0);
  const std::string out =
      (std::filesystem::temp_directory_path() / absl::StrCat("meshsmooth_gltf_check_", getpid(), ".glb")).string();
  for (bool draco : {false, true}) {
    if (draco && !draco_compressed) continue;
    (void)scene->Write(scene->surface().positions, out, draco);
    std::remove(out.c_str());
  }
  _exit(0);
}

// The status for a child of ReadInChildFirst that ended with `wait_status` after writing `report`:
// a crash in Draco's frames refuses the file (InvalidArgument), a crash in ours or in frames no
// name tells is a bug to report (Internal). The report goes with it (kCrashReportPayload).
absl::Status ChildCrashStatus(const std::string& path, int wait_status, const std::string& report) {
  const CrashReport crash = ReadCrashReport(report);
  std::string what = crash.kind;
  if (what.empty()) {
    what = WIFSIGNALED(wait_status) ? absl::StrCat("signal ", WTERMSIG(wait_status))
                                    : absl::StrCat("exit status ", WEXITSTATUS(wait_status));
  }
  if (!crash.frames.empty()) {
    const size_t shown = std::min<size_t>(crash.frames.size(), 3);
    absl::StrAppend(&what, " in ", absl::StrJoin(crash.frames.begin(), crash.frames.begin() + shown, " <- "));
  }
  absl::StrAppend(&what, "; tried in a child process");
  const char* step = report.starts_with(kSceneRead) ? "writer" : "reader";
  absl::Status status;
  switch (crash.owner) {
    case CrashOwner::kDraco:
      status = absl::InvalidArgumentError(
          absl::StrCat(path, ": a malformed glTF file: Draco's glTF ", step, " crashed on it (", what, ")"));
      break;
    case CrashOwner::kMeshsmooth:
      status = absl::InternalError(absl::StrCat(path, ": meshsmooth's glTF ", step,
                                                " crashed on it: a bug in meshsmooth, please report it (", what, ")"));
      break;
    case CrashOwner::kUnknown:
      status = absl::InternalError(absl::StrCat(path, ": the glTF ", step, " crashed on it where no frame names ",
                                                "Draco's code or meshsmooth's: please report it (", what, ")"));
      break;
  }
  status.SetPayload(kCrashReportPayload, absl::Cord(report));
  return status;
}

}  // namespace

absl::StatusOr<GltfScene> GltfScene::ReadInChildFirst(const std::string& path, bool draco_compressed) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return Read(path);  // no pipe, no child: read as before
  std::fflush(nullptr);
  const pid_t child = fork();
  if (child == 0) {
    close(fds[0]);
    ReadAndWriteInChild(path, draco_compressed, fds[1]);
  }
  close(fds[1]);
  if (child < 0) {
    close(fds[0]);
    return Read(path);
  }
  std::string report;
  (void)ReadToEnd(fds[0], &report);  // until the child ends
  close(fds[0]);
  int status = 0;
  pid_t waited;
  while ((waited = waitpid(child, &status, 0)) < 0 && errno == EINTR) {
  }
  if (waited == child && !(WIFEXITED(status) && WEXITSTATUS(status) == 0)) {
    return ChildCrashStatus(path, status, report);
  }
  return Read(path);  // the child read it (or refused it): this process gets the same result
}

const Mesh& GltfScene::surface() const { return impl_->surface; }

GltfCounts GltfScene::counts() const {
  const draco::Scene& s = *impl_->scene;
  return {s.NumNodes(), s.NumMeshGroups(), s.NumMeshes(), static_cast<int>(s.GetMaterialLibrary().NumMaterials()),
          static_cast<int>(s.GetMaterialLibrary().GetTextureLibrary().NumTextures())};
}

std::vector<std::string> GltfScene::stale() const {
  int tangents = 0;
  for (int m = 0; m < impl_->scene->NumMeshes(); ++m) {
    tangents +=
        impl_->scene->GetMesh(draco::MeshIndex(m)).GetNamedAttribute(draco::GeometryAttribute::TANGENT) != nullptr;
  }
  std::vector<std::string> out;
  if (tangents > 0) {
    out.push_back(
        absl::StrCat("the tangents of ", tangents, " glTF primitives (written as they were, not recomputed)"));
  }
  if (!impl_->texcoords.has_value()) {
    out.push_back("texture coordinates bit for bit (the file's JSON could not be followed: Draco's rounding stays)");
  }
  return out;
}

absl::Status GltfScene::Write(const std::vector<Vec3>& positions, const std::string& path, bool draco_compressed) {
  if (positions.size() != impl_->surface.positions.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected ", impl_->surface.positions.size(), " positions, got ", positions.size()));
  }
  // The bound every writer keeps (a non-finite value would be written as one no reader takes).
  for (size_t v = 0; v < positions.size(); ++v) {
    if (absl::Status s = CheckCoordinates(positions[v], "vertex", static_cast<int64_t>(v)); !s.ok()) return s;
  }
  draco::Scene& scene = *impl_->scene;
  for (int m = 0; m < scene.NumMeshes(); ++m) {
    draco::Mesh& dm = scene.GetMesh(draco::MeshIndex(m));
    const int pos_id = dm.GetNamedAttributeId(draco::GeometryAttribute::POSITION);
    if (pos_id < 0) continue;
    draco::PointAttribute* pos = dm.attribute(pos_id);
    const int32_t first = impl_->first[m];
    const Vec3 offset = impl_->offset[m];
    // Positions per value; the normals' sums per position value, area-weighted.
    std::vector<Vec3> value_position(pos->size());
    for (uint32_t p = 0; p < dm.num_points(); ++p) {
      const Vec3 q = positions[first + p] - offset;
      const draco::AttributeValueIndex avi = pos->mapped_index(draco::PointIndex(p));
      if (avi.value() >= value_position.size()) continue;
      value_position[avi.value()] = q;
      if (pos->data_type() == draco::DT_FLOAT32) {
        const float v[3] = {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
        pos->SetAttributeValue(avi, v);
      } else if (pos->data_type() == draco::DT_FLOAT64) {
        const double v[3] = {q.x, q.y, q.z};
        pos->SetAttributeValue(avi, v);
      } else {
        return absl::InvalidArgumentError(absl::StrCat("glTF primitive ", m, ": positions that are not floats"));
      }
    }
    const int nrm_id = dm.GetNamedAttributeId(draco::GeometryAttribute::NORMAL);
    draco::PointAttribute* nrm = nrm_id >= 0 ? dm.attribute(nrm_id) : nullptr;
    if (nrm != nullptr && nrm->data_type() == draco::DT_FLOAT32 && nrm->num_components() == 3) {
      std::vector<Vec3> sum(pos->size());
      for (uint32_t f = 0; f < dm.num_faces(); ++f) {
        const draco::Mesh::Face& face = dm.face(draco::FaceIndex(f));
        uint32_t v[3];
        bool inside = true;
        for (int k = 0; k < 3; ++k) {
          v[k] = pos->mapped_index(face[k]).value();
          inside = inside && v[k] < sum.size();
        }
        if (!inside) continue;
        const Vec3 fn = Cross(value_position[v[1]] - value_position[v[0]], value_position[v[2]] - value_position[v[0]]);
        for (int k = 0; k < 3; ++k) sum[v[k]] += fn;
      }
      for (uint32_t p = 0; p < dm.num_points(); ++p) {
        const uint32_t value = pos->mapped_index(draco::PointIndex(p)).value();
        if (value >= sum.size()) continue;
        const Vec3& s = sum[value];
        const double len = Norm(s);
        if (!(len > 0.0) || !std::isfinite(len)) continue;  // keep the old normal
        const float v[3] = {static_cast<float>(s.x / len), static_cast<float>(s.y / len),
                            static_cast<float>(s.z / len)};
        nrm->SetAttributeValue(nrm->mapped_index(draco::PointIndex(p)), v);
      }
    }
    dm.SetCompressionEnabled(draco_compressed);
    if (draco_compressed) {
      draco::DracoCompressionOptions options;
      options.quantization_position.SetQuantizationBits(16);
      options.quantization_bits_tex_coord = 16;
      options.quantization_bits_normal = 12;
      dm.SetCompressionOptions(options);
    }
  }
  UseDracoFileIo();
  if (absl::Status s = WriteNamedAfter(scene, impl_->images, path); !s.ok()) return s;
  // Plain accessors carry the input's texture coordinates bit for bit; compressed ones are
  // quantized anyway.
  if (!draco_compressed && impl_->texcoords.has_value()) {
    if (absl::StatusOr<int64_t> n = RestoreTexcoords(path, *impl_->texcoords); !n.ok()) return n.status();
  }
  return absl::OkStatus();
}

}  // namespace meshsmooth
