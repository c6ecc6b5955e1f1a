// Helpers over a mesh's corner attributes (core/mesh.h): per-vertex views of them and normals
// recomputed from the positions.
#pragma once

#include <optional>
#include <vector>

#include "core/mesh.h"

namespace meshsmooth {

// The attribute as one value per vertex (components x vertices) when every corner of each
// vertex names the same value (no seam); vertices no corner names get zeros. Nothing when the
// attribute is empty, its corners do not match the triangles, or some vertex has two values.
std::optional<std::vector<double>> PerVertexValues(const Mesh& mesh, const CornerAttribute& a);

// True when float32 holds every value exactly (infinities and NaN count as held): the writers
// store such values (texture coordinates, vertex properties) as float32, bit for bit, and the
// others as float64.
bool AllFloat32(const std::vector<double>& values);

// Unit normals from the positions, laid out as `layout` (entries and corners kept): each entry
// gets the area-weighted normal of the usable triangles whose corners name it, so a vertex with
// several entries (a hard edge) keeps them apart. An empty layout gives one entry per vertex.
// An entry no usable triangle names, or whose faces cancel, keeps its old value (or 0, 0, 1).
CornerAttribute FreshNormals(const Mesh& mesh, const CornerAttribute& layout);

}  // namespace meshsmooth
