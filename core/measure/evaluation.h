// How close a smoothed (or noisy) mesh is to the clean mesh it came from, by the measures of the
// mesh-denoising literature: distance to the clean *surface*, face-normal error overall and
// next to creases, volume change, flipped faces, and the paper's regularity (edge-length CV,
// smallest angle). The quality benchmark (bench/quality.cc, docs/quality.md) and the tests
// that hold flows and defaults to its figures measure with this.
//
// The result must have the clean mesh's connectivity (the flows never change it): face f of
// the result is compared with face f of the clean mesh, vertex i's distance is to the whole
// clean surface. Distances are in units of the clean mesh's mean edge length h.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "core/measure/surface_distance.h"
#include "core/mesh.h"
#include "core/topology.h"

namespace meshsmooth {

// A face is next to a crease when one of its edges has a dihedral angle (between the two
// faces' normals) above this many degrees in the clean mesh.
inline constexpr double kCreaseAngleDeg = 30.0;
// A face lies in fine detail when the clean surface turns by more than this many degrees within
// it: the clean area-weighted normals at two of its corners are further apart. That is detail at
// the scale of the sampling (sharp creases included), where the surface turns within a face as
// much as noise of 0.1-0.2 h turns a face's normal (the noisy inputs' normal errors in
// docs/quality.md). The quality benchmark counts the flipped faces there apart.
inline constexpr double kFineDetailTurnDeg = 20.0;

struct Quality {
  // Distance from each vertex a usable face touches to the clean surface, over h.
  double rms_distance = 0.0;
  double max_distance = 0.0;
  // Mean angle between each face's normal and the same face's clean normal, in degrees, over
  // the faces with a normal in both meshes; and over those next to a crease (NaN if none).
  double normal_error_deg = 0.0;
  double crease_normal_error_deg = 0.0;
  // 100 (V / V_clean - 1) for a closed clean mesh, NaN for an open one.
  double volume_change_percent = 0.0;
  // Measured faces, not folded in the clean mesh (GroundTruth::folded_faces), whose normal
  // points against the clean one (dot product < 0). A face folded in the clean mesh has no
  // trustworthy orientation: a smoothing that unfolds it would count as turning it over.
  int64_t flipped_faces = 0;
  // Of those, the faces in fine detail (kFineDetailTurnDeg).
  int64_t flipped_in_fine_detail = 0;
  double edge_length_cv = 0.0;  // ComputeMetrics of the result
  double min_angle_deg = 0.0;
  int64_t non_finite_vertices = 0;  // when > 0 the distances are NaN
};

// The clean mesh, with what every evaluation against it needs computed once: its topology, h,
// volume, face normals, crease faces and the surface's search structure.
class GroundTruth {
 public:
  // `clean`'s coordinates must be finite.
  explicit GroundTruth(Mesh clean, double crease_angle_deg = kCreaseAngleDeg);

  // `result` against the clean mesh. InvalidArgument when the vertex counts or the triangles
  // differ.
  absl::StatusOr<Quality> Evaluate(const Mesh& result) const;

  const Mesh& mesh() const { return mesh_; }
  const Topology& topology() const { return topo_; }
  const ValidationReport& report() const { return report_; }
  double mean_edge_length() const { return h_; }  // h
  bool closed() const { return report_.closed(); }
  double signed_volume() const { return volume_; }
  // Usable faces whose normal is defined (area above the validation report's zero-area
  // threshold) and, of those, faces next to a crease.
  int64_t measured_faces() const { return measured_faces_; }
  int64_t crease_faces() const { return crease_faces_; }
  // Measured faces folded in the clean mesh: across one of their edges the other face's normal
  // points more than 90 degrees away (scans and coarse models hold a few hundred).
  int64_t folded_faces() const { return folded_faces_; }
  // Measured faces in fine detail (kFineDetailTurnDeg).
  int64_t fine_detail_faces() const { return fine_detail_faces_; }
  const SurfaceDistance& surface() const { return surface_; }

 private:
  Mesh mesh_;
  ValidationReport report_;
  Topology topo_;
  double h_ = 0.0, volume_ = 0.0;
  double zero_cross_ = 0.0;          // |cross| below this: a zero-area face (twice the area threshold)
  std::vector<Vec3> face_cross_;     // per topo_.faces entry: cross product of the clean face
  std::vector<uint8_t> face_class_;  // per topo_.faces entry: kSkipped, kPlain or kCrease
  int64_t measured_faces_ = 0, crease_faces_ = 0, folded_faces_ = 0, fine_detail_faces_ = 0;
  std::vector<uint8_t> folded_;  // per topo_.faces entry
  std::vector<uint8_t> fine_;    // per topo_.faces entry: in fine detail
  SurfaceDistance surface_;
};

}  // namespace meshsmooth
