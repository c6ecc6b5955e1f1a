// Draco bytes <-> Mesh.
//
// The default (sequential, lossless) keeps vertex order and exact float32 positions, so vertex
// i of a decoded result is vertex i of what was encoded. Edgebreaker compresses better but
// reorders vertices and faces; it drops faces with a repeated index and the vertices no other
// face uses, so it is refused for meshes that have such vertices. Quantization (1-24 bits)
// rounds each coordinate to a grid over the bounding box: error <= extent / (2^q - 1) / 2.
//
// Draco's decoder accepts data that its encoders (and meshsmooth) may not index with: faces
// naming points past the point count, several POSITION attributes, attributes without a value
// for some point, coordinates that overflow float32 arithmetic. Every decoding function here
// refuses them with InvalidArgument before anything else reads the mesh, and the encoders
// refuse to write what Draco could not decode to the same vertices.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/mesh.h"
#include "core/util/stop_token.h"

namespace draco {
class Mesh;
}  // namespace draco

namespace meshsmooth {

enum class DracoMethod { kSequential, kEdgebreaker };

// Finest position quantization the encoders accept. Draco's encoder holds a histogram of
// ~2^(bits + 2) bytes whatever the mesh (64 MiB at 24 bits, 3.7 GB at 30), and 24 bits over the
// bounding box are already as fine as float32 itself: lossless (0) is the choice beyond.
inline constexpr int kMaxQuantizationBits = 24;

// Largest coordinate magnitude decoded or encoded: 2^100 (about 1.27e30), exact in float32,
// so that a double within it stays within it as a float. Far below float32's 3.4e38, so that
// Draco's quantizer (float32 ranges) and the flows' products of coordinates (areas, volumes,
// squared lengths in double) stay finite.
inline constexpr double kMaxCoordinate = 0x1p100;

// Smallest extent of the positions (largest over x, y, z, as Draco measures it) that quantized
// output takes, unless it is 0: Draco's quantizer computes (2^bits - 1) / extent in float32,
// which overflows below ~2^-104 and turns every decoded coordinate into garbage. 2^-100
// mirrors kMaxCoordinate.
inline constexpr double kMinQuantizedExtent = 0x1p-100;

struct DracoOptions {
  int quantization_bits = 0;  // 0 = lossless (raw float32); otherwise 1..kMaxQuantizationBits
  DracoMethod method = DracoMethod::kSequential;
  int speed = 5;  // Draco's encoding/decoding speed, 0 (best compression) .. 10 (fastest)
};

// How a mesh with corner attributes becomes Draco points: point v is vertex v (with the values
// of its first corner), and each further (vertex, texture coordinate, normal) combination met
// at a corner, i.e. each seam, adds a point after them. So a decoder that welds points by
// position, as the service does, gets back the vertices in their order.
struct DracoPoints {
  std::vector<int32_t> vertex;   // per point: its vertex
  std::vector<int32_t> uv;       // per point: its texture coordinate entry (empty: no UVs)
  std::vector<int32_t> normal;   // per point: its normal entry (empty: no normals)
  std::vector<int32_t> corners;  // per triangle corner: its point (-1 for an out-of-range vertex)
};
DracoPoints SplitAtSeams(const Mesh& mesh);

// Positions are stored as float32; faces with an index out of range are left out. A mesh with
// attributes (Mesh::has_attributes, or colours) is split at its seams (SplitAtSeams) and
// carries them: texture coordinates as TEX_COORD and normals as NORMAL (float32, or float64
// when float32 cannot hold a coordinate exactly), colours as COLOR (uint8) and each vertex
// property as a one-component GENERIC attribute named by the metadata entry "name". Without
// attributes, point i is vertex i and nothing else is stored.
// InvalidArgument for bad options, an empty mesh, a coordinate that is not finite or above
// kMaxCoordinate in magnitude, quantized output of a mesh spanning less than
// kMinQuantizedExtent, and Edgebreaker when it would drop a vertex (one that no face with three
// distinct indices uses).
absl::StatusOr<std::string> EncodeDraco(const Mesh& mesh, const DracoOptions& options = {});

// OK when EncodeDraco() would encode the positions and faces of `mesh` (without its attributes)
// with `options`; otherwise its InvalidArgument: an empty mesh, bad options, a coordinate out of
// range, and for sequential output more than 3 vertices a face (counting the faces with every
// index in range). Edgebreaker's dropped vertices are not checked. For a caller that hands the
// mesh on in memory where it would have encoded it (the CLI's local run).
absl::Status CheckPositionsEncodable(const Mesh& mesh, const DracoOptions& options = {});

// InvalidArgument with a clear message for corrupt bytes, a point cloud, an empty mesh, a mesh
// with no or several POSITION attributes, an attribute without a value for some point, a face
// naming a point past the point count, and a coordinate that is not finite or above
// kMaxCoordinate in magnitude. Vertices are Draco's points (attribute seams stay split).
// The attributes a Mesh holds come along per point (texture coordinates, normals, colours,
// named one-component attributes as vertex properties); the others are named in `dropped`.
// `attributes` false: positions and faces only (a caller that keeps its own attributes).
absl::StatusOr<Mesh> DecodeDraco(std::string_view bytes, std::vector<std::string>* dropped = nullptr,
                                 bool attributes = true);

// The Draco mesh itself, every attribute and its metadata as Draco decoded them, for a caller
// that hands it on to Draco (the glTF writer); the same checks and errors as DecodeDraco().
absl::StatusOr<std::unique_ptr<draco::Mesh>> DecodeDracoMesh(std::string_view bytes);

// Vertices a Draco mesh may have: an int32 holds every index.
inline constexpr int64_t kMaxDracoVertices = std::numeric_limits<int32_t>::max();

// The faces and points Draco mesh bytes declare at their head, before any data: what a server
// sizes a job by from the first chunk of its upload. Sequential data declares exactly its faces
// and points; Edgebreaker data an upper bound of its points (with its split symbols). nullopt
// when `head` does not yet hold them (or is not a Draco mesh: the decoder says what is wrong).
// Nothing is checked here: the counts are what the bytes say, the decoder checks them.
struct DracoCounts {
  int64_t faces = 0;
  int64_t points = 0;
};
std::optional<DracoCounts> DracoDeclaredCounts(std::string_view head);

// Per-vertex values stored as a one-component Draco GENERIC attribute, named by the attribute
// metadata entry "name" (how Draco files label generic data).
struct GenericAttribute {
  std::string name;
  std::variant<std::vector<uint8_t>, std::vector<float>> values;  // one per vertex
};

// The values of the one-component attribute whose metadata "name" is `name`, converted to
// float, one per point of DecodeDraco(bytes). NotFound when no attribute has that name;
// InvalidArgument as DecodeDraco() for bad bytes.
absl::StatusOr<std::vector<float>> DecodeDracoAttribute(std::string_view bytes, std::string_view name);

// A decoded Draco mesh with every attribute it carries (normals, texture coordinates,
// colours, generic attributes, metadata), for smoothing its positions in place.
//
// Points that a format split at attribute seams (same position, different UV or normal) are
// welded by exact position into one vertex of welded(), so they move together and no crack
// opens; Encode() writes each vertex's new position back to every point of it. Without seams
// (and without coincident points) vertex i is point i.
class DracoMesh {
 public:
  // Same errors as DecodeDraco(); Cancelled or DeadlineExceeded once `stop` fires (checked
  // between Draco's decoder and the steps after it); ResourceExhausted, before Draco's decoder
  // allocates anything, for Edgebreaker data that declares more than 2 * `max_vertices`
  // vertices or 4 * `max_vertices` faces (a 1.4 KB upload could make it allocate 2.8 GB).
  static absl::StatusOr<DracoMesh> Decode(std::string_view bytes, const StopToken& stop = {},
                                          int64_t max_vertices = kMaxDracoVertices);

  DracoMesh(DracoMesh&&) noexcept;
  DracoMesh& operator=(DracoMesh&&) noexcept;
  ~DracoMesh();

  // One vertex per distinct position; faces over those vertices, in Draco's face order.
  const Mesh& welded() const;
  // Moves welded() out instead of copying it (a job smooths that mesh in place); welded() is
  // empty afterwards. Encode() still expects a mesh with welded()'s vertex count.
  Mesh TakeWelded();
  int64_t num_points() const;
  // The positions welded() had, made anew from the decoded points (the same bits): a job that
  // smooths the taken mesh in place needs them only afterwards, and keeping a copy through the
  // run would cost 24 bytes a vertex at its peak.
  std::vector<Vec3> InputPositions() const;
  // Points that share their position with an earlier point (welded into it).
  int64_t seam_points() const;

  // The values of the one-component attribute whose metadata "name" is `name` (any integer or
  // floating-point type), converted to float, one per vertex of welded(): a vertex whose points
  // disagree takes the smallest. NotFound when no attribute has that name; InvalidArgument, the
  // message naming the attribute, for more than one component, values that are not numbers, and
  // a point without a value.
  absl::StatusOr<std::vector<float>> VertexValues(std::string_view name) const;

  // OK when Encode() can write this mesh with `options`: InvalidArgument for options out of
  // range, and for Edgebreaker when it would drop a vertex of welded() (one none of whose
  // points is in a face of three distinct points). A job checks this before smoothing.
  absl::Status CheckEncodable(const DracoOptions& options) const;

  // Sets the positions from `smoothed` (same vertex count as welded() had), recomputes normals
  // from them (area-weighted over each point's faces, so hard edges split at seams stay hard),
  // keeps every other attribute unchanged, and encodes. Quantization applies to positions
  // only; other attributes are stored losslessly. `extra` attributes (one value per vertex of
  // welded(), written to each of its points) are added, replacing any attribute of the same
  // name. InvalidArgument when one has the wrong count, when CheckEncodable() fails, when a
  // smoothed coordinate is not finite or above kMaxCoordinate in magnitude, or for quantized
  // output of a mesh spanning less than kMinQuantizedExtent; Cancelled or
  // DeadlineExceeded when `stop` has fired before Draco's encoder starts.
  absl::StatusOr<std::string> Encode(const Mesh& smoothed, const DracoOptions& options = {},
                                     const std::vector<GenericAttribute>& extra = {}, const StopToken& stop = {});

 private:
  struct Impl;
  explicit DracoMesh(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshsmooth
