#include "core/topology.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <utility>

namespace meshsmooth {
namespace {

// Union-find with path halving; indices are int32 like the rest of the mesh. Serves the
// boundary loops and components of the mesh, and the fans around one vertex (Reset() reuses
// the buffer from vertex to vertex, so that per-vertex work allocates nothing).
class DisjointSets {
 public:
  explicit DisjointSets(size_t n = 0) { Reset(n); }
  // n singletons 0 .. n-1.
  void Reset(size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  int32_t Find(int32_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void Union(int32_t a, int32_t b) {
    a = Find(a);
    b = Find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<int32_t> parent_;
};

// One incident face of a vertex v, rotated so that it reads (v, a, b).
struct LocalFace {
  int32_t a, b;
};

// One (neighbour, local face) incidence; sorted by neighbour to group the faces of an edge.
struct Incidence {
  int32_t w, face;
  bool operator<(const Incidence& o) const { return w < o.w || (w == o.w && face < o.face); }
};

// Scratch buffers reused across vertices so the per-vertex work allocates nothing.
struct Scratch {
  std::vector<LocalFace> faces;
  std::vector<Incidence> inc;
  DisjointSets fans;  // of the vertex's faces, joined across its manifold edges
  std::vector<int32_t> ring;
};

// Range of incidences of neighbour w in the sorted list.
std::pair<int32_t, int32_t> FacesOf(const std::vector<Incidence>& inc, int32_t w) {
  auto lo = std::lower_bound(inc.begin(), inc.end(), Incidence{w, std::numeric_limits<int32_t>::min()});
  auto hi = lo;
  while (hi != inc.end() && hi->w == w) ++hi;
  return {static_cast<int32_t>(lo - inc.begin()), static_cast<int32_t>(hi - inc.begin())};
}

int32_t OtherVertex(const LocalFace& f, int32_t w) { return f.a == w ? f.b : f.a; }

// Walks a single fan whose edges have at most two faces. Returns false if the walk does not
// visit every neighbour (then the caller treats the vertex as non-manifold).
bool WalkFan(Scratch& s, int32_t start, int32_t start_face, bool closed, int32_t distinct) {
  s.ring.clear();
  s.ring.push_back(start);
  int32_t cur = start, face = start_face;
  const int32_t limit = static_cast<int32_t>(s.faces.size()) + 1;
  for (int32_t step = 0; step < limit; ++step) {
    const int32_t next = OtherVertex(s.faces[face], cur);
    if (closed && next == start) break;
    s.ring.push_back(next);
    auto [lo, hi] = FacesOf(s.inc, next);
    int32_t other = -1;
    for (int32_t i = lo; i < hi; ++i) {
      if (s.inc[i].face != face) other = s.inc[i].face;
    }
    if (other < 0) break;  // reached the other boundary edge
    cur = next;
    face = other;
  }
  return static_cast<int32_t>(s.ring.size()) == distinct;
}

// Up to this many faces the closed-fan check compares every pair (fast for the usual valence
// 4-8); above it looks the faces up in a sorted list, so that a vertex of valence k costs
// O(k log k), not O(k^2) (pairs would take ~10 s on a fan of valence 120,000).
constexpr int32_t kPairwiseFanFaces = 32;

// The face whose a is `b`, or -1 when none is; -2 when two are (a repeated neighbour).
int32_t FaceFrom(const Scratch& s, int32_t b) {
  const int32_t k = static_cast<int32_t>(s.faces.size());
  int32_t next = -1;
  if (k <= kPairwiseFanFaces) {
    for (int32_t j = 0; j < k; ++j) {
      if (s.faces[j].a != b) continue;
      if (next >= 0) return -2;
      next = j;
    }
    return next;
  }
  auto it = std::lower_bound(s.inc.begin(), s.inc.end(), Incidence{b, std::numeric_limits<int32_t>::min()});
  if (it == s.inc.end() || it->w != b) return -1;
  if (it + 1 != s.inc.end() && (it + 1)->w == b) return -2;
  return it->face;
}

// The common case: v is an interior vertex of a consistently oriented manifold. Its k >= 3
// faces (v, a, b) then chain into a single cycle, face i followed by the one face whose a is
// i's b, through k distinct neighbours a. On success s.ring holds the cycle from faces[0].a,
// the order WalkFan gives such a fan. Any other fan (boundary, non-manifold, inconsistent
// orientation, repeated neighbour) returns false and takes the general path.
bool ConsistentClosedFan(Scratch& s) {
  const int32_t k = static_cast<int32_t>(s.faces.size());
  if (k < 3) return false;
  if (k > kPairwiseFanFaces) {  // the faces by their a, for FaceFrom
    s.inc.clear();
    for (int32_t i = 0; i < k; ++i) s.inc.push_back({s.faces[i].a, i});
    std::sort(s.inc.begin(), s.inc.end());
  }
  s.ring.clear();
  int32_t face = 0;
  for (int32_t step = 0; step < k; ++step) {
    if (step > 0 && face == 0) return false;  // a shorter cycle: more than one fan
    s.ring.push_back(s.faces[face].a);
    const int32_t next = FaceFrom(s, s.faces[face].b);
    // -2: two faces continue from b, a repeated neighbour; -1: b is a boundary neighbour, or
    // an edge is oriented against the others.
    if (next < 0) return false;
    face = next;
  }
  // Back at face 0 after exactly k steps: the k faces were visited once each, and every a had
  // a single predecessor, so the k neighbours are distinct, each in exactly two faces.
  return face == 0;
}

// What ProcessVertices finds in its range of vertices.
struct RangeResult {
  std::vector<int32_t> ring;                          // the range's rings, in vertex order
  std::vector<std::pair<int32_t, int32_t>> boundary;  // boundary edges (v < w)
  ValidationReport counts;                            // only the per-vertex counts are used
};

// Meshes below this build their topology on one thread.
constexpr int32_t kParallelTopologyThreshold = 50000;

// Fans, rings, kinds and edge counts of vertices [begin, end). Writes kind[v] and, relative to
// the range's own ring, ring_offsets[v + 1]; each edge is counted at its smaller endpoint and
// each set of duplicate faces at its smallest vertex, so ranges never count a thing twice.
// Returns early, the range unfinished, once `stop` fires.
void ProcessVertices(const std::vector<int32_t>& vf_offsets, const std::vector<LocalFace>& vf, int32_t begin,
                     int32_t end, Topology& topo, RangeResult& out, const StopToken& stop) {
  ValidationReport& r = out.counts;
  // A manifold vertex's ring has as many entries as its fan has faces (one more on a boundary):
  // reserved once, the range's ring does not grow by doubling past that.
  out.ring.reserve(static_cast<size_t>(vf_offsets[end] - vf_offsets[begin]) + (end - begin) / 16 + 64);
  Scratch s;
  std::vector<std::pair<int32_t, int32_t>> owned;  // (middle, largest) of faces whose smallest vertex is v
  for (int32_t v = begin; v < end; ++v) {
    if ((v - begin) % kStopPollInterval == 0 && stop.Fired()) return;
    s.faces.clear();
    owned.clear();
    for (int32_t i = vf_offsets[v]; i < vf_offsets[v + 1]; ++i) {
      const auto [a, b] = vf[i];
      s.faces.push_back({a, b});
      if (v < a && v < b) owned.push_back(std::minmax(a, b));
    }
    std::sort(owned.begin(), owned.end());
    for (size_t i = 1; i < owned.size(); ++i) r.duplicate_faces += owned[i] == owned[i - 1];
    const int32_t nf = static_cast<int32_t>(s.faces.size());
    if (nf == 0) {
      ++r.unreferenced_vertices;
      topo.ring_offsets[v + 1] = static_cast<int32_t>(out.ring.size());
      continue;
    }
    if (ConsistentClosedFan(s)) {
      for (int32_t w : s.ring) r.edges += v < w;
      topo.kind[v] = VertexKind::kInterior;
      out.ring.insert(out.ring.end(), s.ring.begin(), s.ring.end());
      topo.ring_offsets[v + 1] = static_cast<int32_t>(out.ring.size());
      continue;
    }
    s.inc.clear();
    for (int32_t i = 0; i < nf; ++i) {
      s.inc.push_back({s.faces[i].a, i});
      s.inc.push_back({s.faces[i].b, i});
    }
    std::sort(s.inc.begin(), s.inc.end());
    s.fans.Reset(nf);

    int32_t distinct = 0, boundary_start = -1, boundary_start_face = -1;
    bool has_nonmanifold_edge = false, has_boundary_edge = false;
    for (size_t i = 0; i < s.inc.size();) {
      size_t j = i;
      while (j < s.inc.size() && s.inc[j].w == s.inc[i].w) ++j;
      const int32_t w = s.inc[i].w;
      const size_t count = j - i;
      ++distinct;
      if (count == 1) {
        has_boundary_edge = true;
        // Prefer the neighbour from which the fan runs in the faces' own orientation.
        if (boundary_start < 0 || s.faces[s.inc[i].face].a == w) {
          boundary_start = w;
          boundary_start_face = s.inc[i].face;
        }
        if (v < w) {
          ++r.boundary_edges;
          out.boundary.emplace_back(v, w);
        }
      } else if (count == 2) {
        const int32_t f0 = s.inc[i].face, f1 = s.inc[i + 1].face;
        s.fans.Union(f0, f1);
        if (v < w && (s.faces[f0].a == w) == (s.faces[f1].a == w)) {
          ++r.inconsistently_oriented_edges;
        }
      } else {
        has_nonmanifold_edge = true;
        if (v < w) ++r.nonmanifold_edges;
      }
      if (v < w) ++r.edges;
      i = j;
    }
    int32_t fans = 0;
    for (int32_t i = 0; i < nf; ++i) fans += s.fans.Find(i) == i;
    if (fans > 1) ++r.nonmanifold_vertices;

    bool walked = false;
    if (fans == 1 && !has_nonmanifold_edge) {
      walked = has_boundary_edge ? WalkFan(s, boundary_start, boundary_start_face, false, distinct)
                                 : WalkFan(s, s.faces[0].a, 0, true, distinct);
    }
    if (walked) {
      topo.kind[v] = has_boundary_edge ? VertexKind::kBoundary : VertexKind::kInterior;
      out.ring.insert(out.ring.end(), s.ring.begin(), s.ring.end());
    } else {
      topo.kind[v] = VertexKind::kNonManifold;
      for (size_t i = 0; i < s.inc.size(); ++i) {
        if (i == 0 || s.inc[i].w != s.inc[i - 1].w) out.ring.push_back(s.inc[i].w);
      }
    }
    topo.ring_offsets[v + 1] = static_cast<int32_t>(out.ring.size());
  }
}

}  // namespace

Topology BuildTopology(const Mesh& mesh, ValidationReport* report, const StopToken& stop) {
  const int32_t n = mesh.num_vertices();
  ValidationReport r;
  r.vertices = n;
  r.faces = mesh.num_triangles();

  Topology topo;
  topo.kind.assign(n, VertexKind::kIsolated);
  topo.ring_offsets.assign(static_cast<size_t>(n) + 1, 0);
  topo.faces.reserve(mesh.triangles.size());
  for (int32_t f = 0; f < mesh.num_triangles(); ++f) {
    const Triangle& t = mesh.triangles[f];
    if (IsUsableTriangle(t, n)) {
      topo.faces.push_back(f);
    } else if (IndexOutOfRange(t, n)) {
      ++r.faces_out_of_range;
    } else {
      ++r.faces_repeated_index;
    }
  }

  // Vertex -> incident usable faces, each rotated to read (v, a, b), by counting sort: the
  // per-vertex work then reads its faces contiguously instead of from the whole face array.
  std::vector<int32_t> vf_offsets(static_cast<size_t>(n) + 1, 0);
  for (int32_t f : topo.faces) {
    for (int32_t v : mesh.triangles[f]) ++vf_offsets[v + 1];
  }
  std::partial_sum(vf_offsets.begin(), vf_offsets.end(), vf_offsets.begin());
  std::vector<LocalFace> vf(vf_offsets.back());
  {
    std::vector<int32_t> fill(vf_offsets.begin(), vf_offsets.end() - 1);
    for (int32_t f : topo.faces) {
      const Triangle& t = mesh.triangles[f];
      vf[fill[t[0]]++] = {t[1], t[2]};
      vf[fill[t[1]]++] = {t[2], t[0]};
      vf[fill[t[2]]++] = {t[0], t[1]};
    }
  }

  // Coordinates: non-finite count and the bounding box of the finite ones.
  BoundingBox box;
  for (const Vec3& p : mesh.positions) {
    if (!IsFinite(p)) {
      ++r.non_finite_vertices;
      continue;
    }
    box.Add(p);
  }
  const double diag2 = box.diagonal() * box.diagonal();
  const int64_t usable = static_cast<int64_t>(topo.faces.size());
  int64_t zero_area = 0;
#pragma omp parallel for schedule(static) reduction(+ : zero_area) if (n >= kParallelTopologyThreshold)
  for (int64_t i = 0; i < usable; ++i) {
    const Triangle& t = mesh.triangles[topo.faces[i]];
    const Vec3& p0 = mesh.positions[t[0]];
    const double area = 0.5 * Norm(Cross(mesh.positions[t[1]] - p0, mesh.positions[t[2]] - p0));
    zero_area += area < 1e-12 * diag2;  // NaN areas compare false: not counted
  }
  r.zero_area_faces = zero_area;

  // The per-vertex work (fans, rings, edge counts) in contiguous vertex ranges, one per
  // thread; rings are concatenated in range order, so the result does not depend on threads.
  const int threads = n >= kParallelTopologyThreshold ? std::max(1, omp_get_max_threads()) : 1;
  std::vector<RangeResult> parts(threads);
#pragma omp parallel for schedule(static, 1) num_threads(threads) if (threads > 1)
  for (int part = 0; part < threads; ++part) {
    const int32_t begin = static_cast<int32_t>(int64_t{n} * part / threads);
    const int32_t end = static_cast<int32_t>(int64_t{n} * (part + 1) / threads);
    ProcessVertices(vf_offsets, vf, begin, end, topo, parts[part], stop);
  }
  // The faces around each vertex are not needed past the rings: 24 bytes a face, freed before
  // the rings are joined (the peak of the job's memory on large meshes).
  std::vector<LocalFace>().swap(vf);
  std::vector<int32_t>().swap(vf_offsets);
  if (stop.Fired()) {  // the rings are unfinished: what is left would only waste time
    if (report != nullptr) *report = r;
    return topo;
  }
  size_t ring_entries = 0;
  for (const RangeResult& q : parts) ring_entries += q.ring.size();
  topo.ring.reserve(ring_entries);
  DisjointSets boundary_sets(n);
  std::vector<uint8_t> on_boundary(n, 0);
  for (int part = 0; part < threads; ++part) {
    RangeResult& q = parts[part];
    const int32_t begin = static_cast<int32_t>(int64_t{n} * part / threads);
    const int32_t end = static_cast<int32_t>(int64_t{n} * (part + 1) / threads);
    const int32_t base = static_cast<int32_t>(topo.ring.size());
    for (int32_t v = begin; v < end; ++v) topo.ring_offsets[v + 1] += base;
    topo.ring.insert(topo.ring.end(), q.ring.begin(), q.ring.end());
    std::vector<int32_t>().swap(q.ring);
    for (const auto& [a, b] : q.boundary) {
      boundary_sets.Union(a, b);
      on_boundary[a] = on_boundary[b] = 1;
    }
    r.unreferenced_vertices += q.counts.unreferenced_vertices;
    r.boundary_edges += q.counts.boundary_edges;
    r.inconsistently_oriented_edges += q.counts.inconsistently_oriented_edges;
    r.nonmanifold_edges += q.counts.nonmanifold_edges;
    r.edges += q.counts.edges;
    r.nonmanifold_vertices += q.counts.nonmanifold_vertices;
    r.duplicate_faces += q.counts.duplicate_faces;
  }

  for (int32_t v = 0; v < n; ++v) {
    if (on_boundary[v] && boundary_sets.Find(v) == v) ++r.boundary_loops;
  }
  DisjointSets components(n);
  for (int32_t f : topo.faces) {
    const Triangle& t = mesh.triangles[f];
    components.Union(t[0], t[1]);
    components.Union(t[1], t[2]);
  }
  for (int32_t v = 0; v < n; ++v) {
    if (topo.kind[v] != VertexKind::kIsolated && components.Find(v) == v) ++r.connected_components;
  }

  if (report != nullptr) *report = r;
  return topo;
}

int64_t SquaredValenceSum(const Topology& topo) {
  int64_t sum = 0;
  for (int32_t v = 0; v < topo.num_vertices(); ++v) sum += int64_t{topo.valence(v)} * topo.valence(v);
  return sum;
}

std::vector<uint8_t> SmallHoleVertices(const Topology& topo, int32_t max_edges) {
  const int32_t n = topo.num_vertices();
  std::vector<uint8_t> small(n, 0), walked(n, 0);
  // A boundary vertex's neighbours along its loop are the first and last entries of its ring.
  auto along = [&](int32_t v, int32_t from) {
    const int32_t first = topo.ring[topo.ring_offsets[v]], last = topo.ring[topo.ring_offsets[v + 1] - 1];
    return first == from ? last : first;
  };
  std::vector<int32_t> loop;
  for (int32_t v = 0; v < n; ++v) {
    if (topo.kind[v] != VertexKind::kBoundary || walked[v]) continue;
    loop.assign(1, v);
    walked[v] = 1;
    int32_t prev = v, cur = topo.ring[topo.ring_offsets[v + 1] - 1];
    while (cur != v && static_cast<int32_t>(loop.size()) <= max_edges && topo.kind[cur] == VertexKind::kBoundary) {
      loop.push_back(cur);
      walked[cur] = 1;
      const int32_t next = along(cur, prev);
      prev = cur;
      cur = next;
    }
    if (cur != v || static_cast<int32_t>(loop.size()) > max_edges) continue;
    for (int32_t w : loop) small[w] = 1;
  }
  return small;
}

ValidationReport Validate(const Mesh& mesh) {
  ValidationReport r;
  BuildTopology(mesh, &r);
  return r;
}

std::string FormatReport(const ValidationReport& r) {
  std::ostringstream o;
  o << "vertices: " << r.vertices << "\n"
    << "faces: " << r.faces << "\n"
    << "faces dropped (index out of range): " << r.faces_out_of_range << "\n"
    << "faces dropped (repeated index): " << r.faces_repeated_index << "\n"
    << "zero-area faces: " << r.zero_area_faces << "\n"
    << "duplicate faces: " << r.duplicate_faces << "\n"
    << "unreferenced vertices: " << r.unreferenced_vertices << "\n"
    << "non-finite vertices: " << r.non_finite_vertices << "\n"
    << "edges: " << r.edges << "\n"
    << "boundary edges: " << r.boundary_edges << "\n"
    << "boundary loops: " << r.boundary_loops << "\n"
    << "non-manifold edges: " << r.nonmanifold_edges << "\n"
    << "non-manifold vertices: " << r.nonmanifold_vertices << "\n"
    << "inconsistently oriented edges: " << r.inconsistently_oriented_edges << "\n"
    << "connected components: " << r.connected_components << "\n"
    << "closed: " << (r.closed() ? "yes" : "no") << "\n"
    << "manifold: " << (r.manifold() ? "yes" : "no") << "\n"
    << "euler characteristic: " << r.euler_characteristic() << "\n";
  return o.str();
}

}  // namespace meshsmooth
