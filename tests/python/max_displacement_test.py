#!/usr/bin/python3
"""The CLI's --max-displacement, checked with numpy on the files it writes: no vertex farther than
the bound from its input position (to float32 precision), no more flipped faces than the same job
without the bound and no more folded faces than the input, and the summary's count of vertices at the bound equal to a count made
here; on the noisy dragon (Gaussian noise of 0.2 mean edge lengths along the normals) when the
shared data is there, and on a noisy sphere always. Bad bounds exit 2 naming the flag.

Run by ctest: max_displacement_test.py --cli build/client/meshsmooth [--shared DIR]
Prints one line per check and ends with 'N passed, M failed'.
"""
import json
import os
import sys

import numpy as np

from harness import parser, run, run_checks, shared_file

# A vertex is at the bound when it moved at least this share of it (core/measure/metrics.h).
AT_BOUND_SHARE = 0.999
PLY_TYPES = {"float": "<f4", "double": "<f8", "uchar": "u1", "uint8": "u1", "int": "<i4", "int32": "<i4",
             "uint": "<u4", "uint32": "<u4"}


def read_ply(path):
    """(positions as float64 (n, 3), faces (m, 3)) of an ASCII or binary little-endian PLY of
    triangles whose vertex element holds scalar properties only."""
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline().decode("ascii").strip()
            header.append(line)
            if line == "end_header":
                break
        body = f.read()
    fmt = next(w.split()[1] for w in header if w.startswith("format"))
    elements, current = [], None
    for line in header:
        words = line.split()
        if words and words[0] == "element":
            current = (words[1], int(words[2]), [])
            elements.append(current)
        elif words and words[0] == "property":
            current[2].append(words[1:])
    (_, n, vprops), (_, m, fprops) = elements[0], elements[1]
    names = [p[-1] for p in vprops]
    if fmt == "ascii":
        lines = body.decode("ascii").split("\n")
        table = np.array([list(map(float, l.split())) for l in lines[:n]])
        xyz = table[:, [names.index(c) for c in "xyz"]]
        faces = np.array([list(map(int, l.split()))[1:4] for l in lines[n:n + m]])
        return xyz, faces
    assert fmt == "binary_little_endian", fmt
    vtype = np.dtype([(p[-1], PLY_TYPES[p[0]]) for p in vprops])
    vertices = np.frombuffer(body, dtype=vtype, count=n)
    xyz = np.stack([vertices[c].astype(np.float64) for c in "xyz"], axis=1)
    _, count_type, index_type, _ = fprops[0]
    ftype = np.dtype([("k", PLY_TYPES[count_type]), ("v", PLY_TYPES[index_type], 3)])
    faces = np.frombuffer(body, dtype=ftype, count=m, offset=n * vtype.itemsize)
    assert (faces["k"] == 3).all(), "not a triangle mesh"
    return xyz, faces["v"].astype(np.int64)


def write_ply(path, xyz, faces):
    """A binary little-endian PLY with float32 positions."""
    with open(path, "wb") as f:
        f.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(xyz)}\nproperty float x\n"
                 f"property float y\nproperty float z\nelement face {len(faces)}\n"
                 "property list uchar int vertex_indices\nend_header\n").encode("ascii"))
        f.write(xyz.astype("<f4").tobytes())
        ftype = np.dtype([("k", "u1"), ("v", "<i4", 3)])
        table = np.zeros(len(faces), dtype=ftype)
        table["k"], table["v"] = 3, faces
        f.write(table.tobytes())


def face_normals(xyz, faces):
    return np.cross(xyz[faces[:, 1]] - xyz[faces[:, 0]], xyz[faces[:, 2]] - xyz[faces[:, 0]])


def unique_edges(faces):
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(edges, axis=0)


def folded_faces(xyz, faces):
    """Faces back to back with a neighbour across an edge of exactly two faces (normals more than
    90 degrees apart): core/measure/folded_faces.h, counted here on their own."""
    normals = face_normals(xyz, faces)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owner = np.repeat(np.arange(len(faces)), 3)
    key = edges[:, 0] * (int(xyz.shape[0]) + 1) + edges[:, 1]
    order = np.argsort(key, kind="stable")
    key, owner = key[order], owner[order]
    _, start, count = np.unique(key, return_index=True, return_counts=True)
    pairs = start[count == 2]
    a, b = owner[pairs], owner[pairs + 1]
    back = np.einsum("ij,ij->i", normals[a], normals[b]) < 0.0
    folded = np.zeros(len(faces), dtype=bool)
    folded[a[back]] = True
    folded[b[back]] = True
    return int(folded.sum())


def flipped_faces(before, after, faces):
    """Faces whose normal turned by more than 90 degrees."""
    return int((np.einsum("ij,ij->i", face_normals(before, faces), face_normals(after, faces)) < 0.0).sum())


def smooth(cli, source, out, *extra):
    """The CLI's --json summary of smoothing `source` into `out`."""
    r = run([cli, "smooth", source, "-o", out, "--json", *extra], timeout=600)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def check_bound(cli, source, tmp, name, bound, *extra):
    """The job `extra` on `source` with and without `--max-displacement bound`, checked."""
    before, faces = read_ply(source)
    free_summary = smooth(cli, source, os.path.join(tmp, f"{name}-free.ply"), *extra)
    bounded_summary = smooth(cli, source, os.path.join(tmp, f"{name}-bounded.ply"), *extra,
                             "--max-displacement", bound)
    free, free_faces = read_ply(os.path.join(tmp, f"{name}-free.ply"))
    bounded, bounded_faces = read_ply(os.path.join(tmp, f"{name}-bounded.ply"))
    assert (free_faces == faces).all() and (bounded_faces == faces).all(), "the faces changed"
    d = float(bounded_summary["parameters"]["max_displacement"])
    if bound.endswith("h"):
        h = float(bounded_summary["parameters"]["mean_edge_length"])
        assert abs(d - float(bound[:-1]) * h) <= 1e-12 * d, (d, bound, h)
    else:
        assert d == float(bound), (d, bound)
    moved = np.linalg.norm(bounded - before, axis=1)
    rounding = np.abs(bounded).max() * 2.0 ** -23
    assert moved.max() <= d + rounding, f"a vertex moved {moved.max()!r}, beyond the bound {d!r}"
    assert np.linalg.norm(free - before, axis=1).max() > 1.5 * d, "the bound does not bind: the check shows nothing"
    at_bound = int((moved >= AT_BOUND_SHARE * d).sum())
    reported = int(bounded_summary.get("vertices_at_bound", 0))
    assert reported == at_bound, f"the summary counts {reported} vertices at the bound, numpy {at_bound}"
    assert at_bound > len(before) // 100, f"only {at_bound} vertices reached the bound"
    assert abs(float(bounded_summary["max_displacement"]) - moved.max()) <= rounding
    flips = (flipped_faces(before, bounded, faces), flipped_faces(before, free, faces))
    assert flips[0] <= flips[1], f"flipped faces: {flips[0]} with the bound, {flips[1]} without"
    # A bound below the noise leaves some of the noise's folds, which the job without it removes:
    # never more than the input had.
    folds = (folded_faces(bounded, faces), folded_faces(free, faces), folded_faces(before, faces))
    assert folds[0] <= folds[2], f"folded faces: {folds[0]} with the bound, {folds[2]} in the input"
    print(f"  {name}: bound {d:.6g}, {at_bound} of {len(before)} vertices at it, largest move {moved.max():.6g}; "
          f"flipped {flips[0]} (without the bound {flips[1]}), folded {folds[0]} (without {folds[1]}, input {folds[2]})",
          flush=True)


def noisy_dragon(shared, path):
    """The Stanford dragon with Gaussian noise of 0.2 h along its area-weighted vertex normals."""
    xyz, faces = read_ply(os.path.join(shared, "data", "meshes", "stanford-dragon.ply"))
    edges = unique_edges(faces)
    h = np.linalg.norm(xyz[edges[:, 0]] - xyz[edges[:, 1]], axis=1).mean()
    normals = np.zeros_like(xyz)
    fn = face_normals(xyz, faces)
    for k in range(3):
        np.add.at(normals, faces[:, k], fn)
    length = np.linalg.norm(normals, axis=1)
    length[length == 0.0] = 1.0
    offsets = np.random.default_rng(1).normal(0.0, 0.2 * h, len(xyz))
    write_ply(path, xyz + normals / length[:, None] * offsets[:, None], faces)


def checks(a, check, tmp):
    cli = a.cli

    def bad_bounds_exit_2():
        for bad in ("-0.1", "nan", "inf", "0.1x", "h", "-1h"):
            r = run([cli, "smooth", "builtin:noisy-sphere", "-o", os.path.join(tmp, "x.ply"),
                     f"--max-displacement={bad}"])
            assert r.returncode == 2 and "--max-displacement" in r.stderr, (bad, r.returncode, r.stderr)
        r = run([cli, "smooth", "--help"])
        assert "--max-displacement" in r.stdout and "0.5h" in r.stdout, "--help does not describe the flag"
    check("a negative, NaN, infinite or malformed --max-displacement exits 2 naming the flag; --help has it",
          bad_bounds_exit_2)

    sphere = os.path.join(tmp, "sphere.ply")
    # The built-in noisy sphere as a file: one laplacian iteration of a step too small to move it.
    r = run([cli, "smooth", "builtin:noisy-sphere", "-o", sphere, "--flow", "laplacian", "--iterations", "1",
             "--step", "1e-9", "-q"])
    assert r.returncode == 0, r.stderr
    check("the noisy sphere's default job keeps --max-displacement 0.01 and counts the vertices at it as numpy does",
          check_bound, cli, sphere, tmp, "sphere-default", "0.01")
    check("taubin, 20 iterations, keeps --max-displacement 0.1h on the noisy sphere",
          check_bound, cli, sphere, tmp, "sphere-taubin", "0.1h", "--flow", "taubin", "--iterations", "20")
    if shared_file(a.shared, "meshes", "stanford-dragon.ply"):
        dragon = os.path.join(tmp, "dragon-noisy.ply")
        noisy_dragon(a.shared, dragon)
        check("the noisy dragon's default job keeps --max-displacement 0.1h: every vertex within it, no more flipped "
              "faces than without it, the summary's count of vertices at it equal to numpy's",
              check_bound, cli, dragon, tmp, "dragon-default", "0.1h")
        check("the noisy dragon, bilateral_normal for 3 iterations, keeps --max-displacement 0.1h",
              check_bound, cli, dragon, tmp, "dragon-bilateral", "0.1h", "--flow", "bilateral_normal",
              "--iterations", "3")


def main():
    ap = parser(__doc__, required=("cli",), optional=("shared",))
    a = ap.parse_args()
    return run_checks(lambda c, tmp: checks(a, c.check, tmp), tmp_prefix="meshsmooth-maxdisp-")


if __name__ == "__main__":
    sys.exit(main())
