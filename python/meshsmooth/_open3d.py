"""Open3D interop: smooth an open3d.geometry.TriangleMesh. Open3D is imported only when asked
for (Debian's python3-open3d); without it smooth_open3d raises ImportError saying so."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import open3d


def smooth_open3d(mesh: "open3d.geometry.TriangleMesh", **params: Any) -> "open3d.geometry.TriangleMesh":
    """A smoothed copy of `mesh` (its vertices and triangles in the same order): vertex colours
    come back as they were, vertex normals recomputed from the smoothed positions (when the mesh
    has them), triangle normals too. `params` are meshsmooth.smooth()'s keyword parameters
    (the job's, `server` and the rest); use smooth() itself for the summary.

    Raises ImportError without Open3D, meshsmooth.Error as smooth() does.
    """
    try:
        import open3d as o3d
    except ImportError as e:
        raise ImportError("meshsmooth.smooth_open3d needs Open3D: apt-get install python3-open3d") from e
    from . import smooth

    attributes = {}
    if mesh.has_vertex_colors():
        attributes["colors"] = np.asarray(mesh.vertex_colors)
    if mesh.has_vertex_normals():
        attributes["normals"] = np.asarray(mesh.vertex_normals)
    result = smooth(np.asarray(mesh.vertices), np.asarray(mesh.triangles), attributes=attributes, **params)
    out = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(result.vertices),
                                    o3d.utility.Vector3iVector(result.faces.astype(np.int32)))
    if "colors" in result.attributes:
        out.vertex_colors = o3d.utility.Vector3dVector(result.attributes["colors"])
    if "normals" in result.attributes:
        out.vertex_normals = o3d.utility.Vector3dVector(result.attributes["normals"])
    if mesh.has_triangle_normals():
        out.compute_triangle_normals()
    return out
