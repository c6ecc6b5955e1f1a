#include "core/topology.h"

#include <cmath>
#include <limits>
#include <map>
#include <regex>
#include <set>

#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/test_data.h"
#include "tests/topology_checks.h"

namespace meshsmooth {
namespace {

// A square split in two triangles: 4 boundary vertices, one boundary loop.
Mesh Square() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

// A hexagonal fan around vertex 0: one interior vertex with a cyclic ring of six.
Mesh Hexagon() {
  Mesh m;
  m.positions.push_back({0, 0, 0});
  for (int k = 0; k < 6; ++k) {
    m.positions.push_back({std::cos(k * M_PI / 3), std::sin(k * M_PI / 3), 0});
  }
  for (int k = 0; k < 6; ++k) m.triangles.push_back({0, 1 + k, 1 + (k + 1) % 6});
  return m;
}

TEST(TopologyTest, InteriorRingIsCyclicAndFollowsFaces) {
  const Mesh m = Hexagon();
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  ASSERT_EQ(t.kind[0], VertexKind::kInterior);
  ASSERT_EQ(t.valence(0), 6);
  // (0, ring[k], ring[k+1]) must be a face with the faces' own orientation.
  std::set<std::array<int32_t, 3>> faces(m.triangles.begin(), m.triangles.end());
  for (int k = 0; k < 6; ++k) {
    const int32_t a = t.ring[t.ring_offsets[0] + k], b = t.ring[t.ring_offsets[0] + (k + 1) % 6];
    EXPECT_TRUE(faces.count({0, a, b})) << a << " " << b;
  }
  for (int v = 1; v <= 6; ++v) {
    EXPECT_EQ(t.kind[v], VertexKind::kBoundary);
    EXPECT_EQ(t.valence(v), 3);
    // The ends of a boundary ring are the neighbours along the boundary.
    const int32_t first = t.ring[t.ring_offsets[v]], last = t.ring[t.ring_offsets[v + 1] - 1];
    EXPECT_NE(first, 0);
    EXPECT_NE(last, 0);
  }
  EXPECT_EQ(r.edges, 12);
  EXPECT_EQ(r.boundary_edges, 6);
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_EQ(r.connected_components, 1);
  EXPECT_EQ(r.euler_characteristic(), 1);
  EXPECT_EQ(r.inconsistently_oriented_edges, 0);
}

TEST(TopologyTest, IcosphereIsClosedManifoldGenusZero) {
  const Mesh m = Icosphere(3);
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  EXPECT_TRUE(testing::IsClosedManifold(r, 2));
  EXPECT_EQ(r.connected_components, 1);
  for (int32_t v = 0; v < t.num_vertices(); ++v) {
    ASSERT_EQ(t.kind[v], VertexKind::kInterior);
    ASSERT_TRUE(t.valence(v) == 5 || t.valence(v) == 6);
  }
}

// An icosphere with three holes apart: one missing face (3 edges), the fan of one vertex (5 or
// 6 edges; the vertex is left without a face) and a polar cap (many edges).
TEST(TopologyTest, SmallHoleVerticesAreThoseOfLoopsOfFewEdges) {
  Mesh m = Icosphere(3);
  auto nearest = [&](const Vec3& to) {
    int32_t best = 0;
    for (int32_t v = 1; v < static_cast<int32_t>(m.positions.size()); ++v) {
      if (Norm(m.positions[v] - to) < Norm(m.positions[best] - to)) best = v;
    }
    return best;
  };
  const int32_t corner = nearest({1, 0, 0}), centre = nearest({-1, 0, 0});
  std::vector<Triangle> kept;
  bool dropped_one = false;
  for (const Triangle& t : m.triangles) {
    const bool at_corner = t[0] == corner || t[1] == corner || t[2] == corner;
    const bool in_fan = t[0] == centre || t[1] == centre || t[2] == centre;
    const bool in_cap = m.positions[t[0]].z > 0.7 || m.positions[t[1]].z > 0.7 || m.positions[t[2]].z > 0.7;
    if (in_fan || in_cap || (at_corner && !dropped_one)) {
      dropped_one |= at_corner;
      continue;
    }
    kept.push_back(t);
  }
  m.triangles = kept;
  ValidationReport r;
  const Topology topo = BuildTopology(m, &r);
  ASSERT_EQ(r.boundary_loops, 3);
  ASSERT_EQ(r.nonmanifold_vertices, 0);
  std::vector<int32_t> on_loop(m.positions.size(), 0);  // which hole a boundary vertex rims
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] != VertexKind::kBoundary) continue;
    on_loop[v] = m.positions[v].z > 0.5 ? 3 : Norm(m.positions[v] - m.positions[centre]) < 0.5 ? 2 : 1;
  }
  for (int32_t max_edges : {2, 3, 6, 8}) {
    const std::vector<uint8_t> small = SmallHoleVertices(topo, max_edges);
    int counts[4] = {0, 0, 0, 0};
    for (int32_t v = 0; v < topo.num_vertices(); ++v) {
      if (small[v]) {
        ASSERT_NE(on_loop[v], 0) << "vertex " << v << " is not on a boundary";
        ++counts[on_loop[v]];
      }
    }
    SCOPED_TRACE(max_edges);
    EXPECT_EQ(counts[1], max_edges >= 3 ? 3 : 0);
    EXPECT_EQ(counts[2] > 0, max_edges >= 6);  // the fan of a valence 5 or 6 vertex
    EXPECT_EQ(counts[3], 0);                   // the cap's loop has more than 8 edges
  }
}

TEST(TopologyTest, RepeatedIndexFaceIsDroppedAndCounted) {
  Mesh m = Square();
  m.triangles.push_back({1, 1, 2});
  const ValidationReport r = Validate(m);
  EXPECT_EQ(r.faces, 3);
  EXPECT_EQ(r.faces_repeated_index, 1);
  EXPECT_EQ(r.faces_out_of_range, 0);
  EXPECT_EQ(r.edges, 5);
}

TEST(TopologyTest, OutOfRangeFaceIsDroppedAndCounted) {
  Mesh m = Square();
  m.triangles.push_back({0, 2, 4});
  m.triangles.push_back({-1, 2, 3});
  m.triangles.push_back({0, 1, std::numeric_limits<int32_t>::max()});
  const ValidationReport r = Validate(m);
  EXPECT_EQ(r.faces_out_of_range, 3);
  EXPECT_EQ(r.dropped_faces(), 3);
  EXPECT_EQ(r.boundary_edges, 4);
}

TEST(TopologyTest, NonManifoldEdgeFlagsItsVertices) {
  // Three triangles sharing edge 0-1 (a "book" with three pages).
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}};
  m.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  EXPECT_EQ(r.nonmanifold_edges, 1);
  EXPECT_EQ(r.nonmanifold_vertices, 2);  // three fans at each end of the spine
  EXPECT_FALSE(r.manifold());
  EXPECT_EQ(t.kind[0], VertexKind::kNonManifold);
  EXPECT_EQ(t.kind[1], VertexKind::kNonManifold);
  EXPECT_EQ(t.kind[2], VertexKind::kBoundary);
  EXPECT_EQ(t.valence(0), 4);
}

TEST(TopologyTest, BowtieVertexIsNonManifold) {
  // Two triangles touching at vertex 0 only.
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  m.triangles = {{0, 1, 2}, {0, 3, 4}};
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  EXPECT_EQ(r.nonmanifold_vertices, 1);
  EXPECT_EQ(r.nonmanifold_edges, 0);
  EXPECT_EQ(t.kind[0], VertexKind::kNonManifold);
  EXPECT_EQ(r.connected_components, 1);
  EXPECT_EQ(r.boundary_loops, 1);  // the two triangles' boundaries meet at vertex 0
}

// Interior vertices of consistently oriented closed fans take a fast path (ConsistentClosedFan);
// these fans look closed from each face but are not one fan of distinct neighbours.
TEST(TopologyTest, ClosedFansThatAreNotOneFanTakeTheGeneralPath) {
  {
    // Two closed tetrahedra sharing vertex 0: its six faces form two 3-cycles.
    Mesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
    m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 5, 4}, {0, 4, 6}, {0, 6, 5}, {4, 5, 6}};
    ValidationReport r;
    const Topology t = BuildTopology(m, &r);
    EXPECT_EQ(t.kind[0], VertexKind::kNonManifold);
    EXPECT_EQ(r.nonmanifold_vertices, 1);
    EXPECT_EQ(t.valence(0), 6);
    EXPECT_EQ(t.kind[1], VertexKind::kInterior);
    EXPECT_EQ(r.edges, 12);
    EXPECT_EQ(r.boundary_edges, 0);
  }
  {
    // A hexagon fan with one face repeated: every face still has a successor, but neighbour 1
    // and 2 follow two faces each.
    Mesh m = Hexagon();
    m.triangles.push_back(m.triangles[0]);
    ValidationReport r;
    const Topology t = BuildTopology(m, &r);
    EXPECT_EQ(r.duplicate_faces, 1);
    EXPECT_NE(t.kind[0], VertexKind::kInterior);
  }
  {
    // The hexagon fan with one face reversed: no face continues from it, yet each of vertex 0's
    // edges has two faces, so the general path still finds an interior vertex.
    Mesh m = Hexagon();
    std::swap(m.triangles[2][1], m.triangles[2][2]);
    ValidationReport r;
    const Topology t = BuildTopology(m, &r);
    EXPECT_EQ(r.inconsistently_oriented_edges, 2);
    EXPECT_EQ(t.kind[0], VertexKind::kInterior);
    EXPECT_EQ(t.valence(0), 6);
  }
}

TEST(TopologyTest, IsolatedVertexIsUnreferenced) {
  Mesh m = Square();
  m.positions.push_back({5, 5, 5});
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  EXPECT_EQ(r.unreferenced_vertices, 1);
  EXPECT_EQ(t.kind[4], VertexKind::kIsolated);
  EXPECT_EQ(t.valence(4), 0);
  EXPECT_EQ(r.connected_components, 1);
}

TEST(TopologyTest, NonFiniteCoordinatesAreCounted) {
  Mesh m = Square();
  m.positions[1].y = std::numeric_limits<double>::quiet_NaN();
  m.positions[2].z = std::numeric_limits<double>::infinity();
  const ValidationReport r = Validate(m);
  EXPECT_EQ(r.non_finite_vertices, 2);
  EXPECT_EQ(r.zero_area_faces, 0);  // NaN areas are not called zero
}

TEST(TopologyTest, EmptyMeshGivesZeroCounts) {
  const Mesh m;
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  EXPECT_EQ(r.vertices, 0);
  EXPECT_EQ(r.faces, 0);
  EXPECT_EQ(r.edges, 0);
  EXPECT_EQ(r.connected_components, 0);
  EXPECT_EQ(t.ring_offsets.size(), 1u);
}

TEST(TopologyTest, ZeroAreaAndDuplicateFacesAreCountedButKept) {
  Mesh m = Square();
  m.positions.push_back({0.5, 0.0, 0.0});  // on edge 0-1: a zero-area sliver
  m.triangles.push_back({0, 4, 1});
  m.triangles.push_back({2, 0, 1});  // same vertex set as face 0
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  EXPECT_EQ(r.zero_area_faces, 1);
  EXPECT_EQ(r.duplicate_faces, 1);
  EXPECT_EQ(t.faces.size(), 4u);
}

TEST(TopologyTest, InconsistentOrientationIsCounted) {
  Mesh m = Square();
  m.triangles[1] = {0, 3, 2};  // flipped relative to face 0 across edge 0-2
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  EXPECT_EQ(r.inconsistently_oriented_edges, 1);
  EXPECT_EQ(t.kind[0], VertexKind::kBoundary);  // still one fan
}

TEST(TopologyTest, NeverCrashesOnGarbageFaces) {
  Mesh m = Icosphere(1);
  uint64_t x = 12345;
  for (int i = 0; i < 2000; ++i) {
    x = x * 6364136223846793005ULL + 1442695040888963407ULL;
    m.triangles.push_back({static_cast<int32_t>(x >> 40) % 50 - 4, static_cast<int32_t>(x >> 20) % 45,
                           static_cast<int32_t>(x >> 50) % 44});
  }
  ValidationReport r;
  const Topology t = BuildTopology(m, &r);
  EXPECT_EQ(r.faces, static_cast<int64_t>(m.triangles.size()));
  EXPECT_EQ(static_cast<int64_t>(t.faces.size()), r.faces - r.dropped_faces());
}

// Reads one integer field of one file's entry in stats.json (a flat, known layout).
int64_t StatsField(const std::string& json, const std::string& file, const std::string& key) {
  const size_t at = json.find("\"" + file + "\"");
  if (at == std::string::npos) return -1;
  const size_t k = json.find("\"" + key, at);
  if (k == std::string::npos) return -1;
  const size_t colon = json.find(':', k);
  return std::stoll(json.substr(colon + 1));
}

// Every real mesh loads, and its counts match stats.json. Definitions agree for every field
// compared here (those of ValidationReport, core/topology.h); fields whose definitions differ
// are not compared.
TEST(TopologyTest, SharedMeshesMatchStatsJson) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  const auto dir = testing::SharedData("meshes");
  absl::StatusOr<std::string> stats = ReadFileBytes((dir / "stats.json").string());
  ASSERT_TRUE(stats.ok()) << stats.status();
  const std::string& json = *stats;
  int checked = 0;
  for (const char* file : {"stanford-bunny.ply", "bunny-small.obj", "max-planck.obj", "fandisk.obj", "camelhead.obj",
                           "turbine.obj", "beetle.obj", "nefertiti.obj", "stanford-dragon.ply"}) {
    SCOPED_TRACE(file);
    absl::StatusOr<Mesh> mesh = ReadMesh((dir / file).string());
    ASSERT_TRUE(mesh.ok()) << mesh.status();
    const ValidationReport r = Validate(*mesh);
    EXPECT_EQ(r.vertices, StatsField(json, file, "vertices"));
    EXPECT_EQ(r.faces, StatsField(json, file, "faces"));
    EXPECT_EQ(r.unreferenced_vertices, StatsField(json, file, "unreferenced_vertices"));
    EXPECT_EQ(r.faces_repeated_index, StatsField(json, file, "faces_with_repeated_index"));
    EXPECT_EQ(r.faces_out_of_range, StatsField(json, file, "bad_indices"));
    EXPECT_EQ(r.zero_area_faces, StatsField(json, file, "zero_area_faces"));
    EXPECT_EQ(r.duplicate_faces, StatsField(json, file, "duplicate_faces"));
    EXPECT_EQ(r.edges, StatsField(json, file, "edges"));
    EXPECT_EQ(r.boundary_edges, StatsField(json, file, "boundary_edges"));
    EXPECT_EQ(r.nonmanifold_edges, StatsField(json, file, "nonmanifold_edges"));
    EXPECT_EQ(r.inconsistently_oriented_edges, StatsField(json, file, "inconsistently_oriented_edges"));
    EXPECT_EQ(r.boundary_loops, StatsField(json, file, "boundary_loops"));
    EXPECT_EQ(r.connected_components, StatsField(json, file, "connected_components"));
    EXPECT_EQ(r.nonmanifold_vertices, StatsField(json, file, "nonmanifold_vertices"));
    EXPECT_EQ(r.euler_characteristic(), StatsField(json, file, "euler_characteristic"));
    ++checked;
  }
  EXPECT_EQ(checked, 9);
}

}  // namespace
}  // namespace meshsmooth
