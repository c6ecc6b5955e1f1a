#!/usr/bin/python3
"""The CLI's local run (no --server), which hands its mesh to the job in memory, against the same
job through a real meshsmoothd: the same output bytes, the same summary but for the timings, the
job id and the result's size (no Draco bytes in memory), the same errors; Ctrl-C and --timeout
stop a local job.

Inputs: built-in shapes, and files written here: survey coordinates in double, an OBJ with
texture coordinates, normals and material lines, a PLY with colours and a property used as the
per-vertex strength, and an OBJ whose vertices repeat positions (welded by the service) with a
degenerate face.

Run by ctest: local_run_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd [--shared DIR]
Prints one line per check and ends with 'N passed, M failed'.
"""
import json
import math
import os
import random
import sys

from harness import Server, interrupt_long_job, parser, run, run_checks, shared_file, write_text


def icosphere(levels):
    """(positions, faces) of a unit icosphere subdivided `levels` times."""
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    for _ in range(levels):
        mid, nf = {}, []

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
                n = math.sqrt(sum(x * x for x in p))
                v.append(tuple(x / n for x in p))
                mid[key] = len(v) - 1
            return mid[key]

        for a, b, c in f:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return v, f


def noisy(points, amount, seed):
    rng = random.Random(seed)
    return [tuple(c + rng.uniform(-amount, amount) for c in p) for p in points]


def write_survey_ply(path):
    """A noisy sphere of radius 12 m around a UTM-like point, in double."""
    v, f = icosphere(3)
    v = noisy([(500123.4567 + 12 * x, 4100456.789 + 12 * y, 312.25 + 12 * z) for x, y, z in v], 0.2, 1)
    lines = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property double x", "property double y",
             "property double z", f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    lines += ["%.10f %.10f %.10f" % p for p in v] + ["3 %d %d %d" % t for t in f]
    write_text(path, "\n".join(lines) + "\n")


def write_attributes_obj(folder):
    """An OBJ with a material library, texture coordinates (a seam: each face's own corners) and
    normals; returns its path."""
    v, f = icosphere(2)
    v = noisy(v, 0.02, 2)
    write_text(os.path.join(folder, "skin.mtl"), "newmtl skin\nKd 0.8 0.6 0.5\n")
    lines = ["mtllib skin.mtl", "o ball"] + ["v %.9f %.9f %.9f" % p for p in v]
    lines += ["vt %.6f %.6f" % (0.5 + math.atan2(p[1], p[0]) / (2 * math.pi), 0.5 + p[2] / 2) for p in v]
    lines += ["vt 0.25 0.75"]
    lines += ["vn %.6f %.6f %.6f" % p for p in v]
    lines += ["usemtl skin", "s 1"]
    for i, (a, b, c) in enumerate(f):
        ta = len(v) + 1 if i % 7 == 0 else a + 1  # every seventh face: a texture seam at its first corner
        lines.append(f"f {a + 1}/{ta}/{a + 1} {b + 1}/{b + 1}/{b + 1} {c + 1}/{c + 1}/{c + 1}")
    path = os.path.join(folder, "attributes.obj")
    write_text(path, "\n".join(lines) + "\n")
    return path


def write_colours_ply(path):
    """Colours and a float property 'quality' in [0, 1] (the strength of --weight quality)."""
    v, f = icosphere(3)
    v = noisy(v, 0.01, 3)
    lines = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property float x", "property float y",
             "property float z", "property uchar red", "property uchar green", "property uchar blue",
             "property float quality", f"element face {len(f)}", "property list uchar int vertex_indices",
             "end_header"]
    for i, (x, y, z) in enumerate(v):
        lines.append("%.7g %.7g %.7g %d %d %d %.3f" % (x, y, z, i % 256, (3 * i) % 256, 200, (x + 1) / 2))
    lines += ["3 %d %d %d" % t for t in f]
    write_text(path, "\n".join(lines) + "\n")


def write_welded_obj(path):
    """Every face of the first half given vertices of its own at the same positions (which the
    service welds), one degenerate face and one vertex no face uses."""
    v, f = icosphere(3)
    v = noisy(v, 0.01, 4)
    out_v, out_f = list(v), []
    for i, (a, b, c) in enumerate(f):
        if i < len(f) // 2:
            out_v += [v[a], v[b], v[c]]
            n = len(out_v)
            out_f.append((n - 3, n - 2, n - 1))
        else:
            out_f.append((a, b, c))
    out_f.append((0, 0, 1))
    out_v.append((3.0, 3.0, 3.0))
    lines = ["v %.9f %.9f %.9f" % p for p in out_v] + ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in out_f]
    write_text(path, "\n".join(lines) + "\n")


def summary_without_run(text):
    """The --json summary less what differs between two runs of one job (times, the id) and the
    result's size; and that size."""
    s = json.loads(text)
    size = int(s.pop("resultBytes", s.pop("result_bytes", 0)))
    for key in ("timings", "jobId", "job_id"):
        s.pop(key, None)
    for f in (s.get("features"),):
        if f:
            f.pop("detectSeconds", None)
            f.pop("detect_seconds", None)
    return s, size


def local_run_checks(a, check, tmp):
    survey = os.path.join(tmp, "survey.ply")
    write_survey_ply(survey)
    attributes = write_attributes_obj(tmp)
    colours = os.path.join(tmp, "colours.ply")
    write_colours_ply(colours)
    welded = os.path.join(tmp, "welded.obj")
    write_welded_obj(welded)
    fixed = os.path.join(tmp, "fixed.txt")
    write_text(fixed, "0 1 2 3 4 5 6 7 8 9\n# held\n40, 41, 42\n")
    cases = [
        ("the default job", "builtin:noisy-sphere", ".ply", []),
        ("the default job, 40,962 vertices", "builtin:noisy-sphere-large", ".ply", []),
        ("the default job, an open mesh", "builtin:noisy-plane", ".obj", []),
        ("taubin, 30 iterations", "builtin:noisy-torus", ".off", ["--flow", "taubin", "--iterations", "30"]),
        ("bilateral_normal with ridges", "builtin:noisy-sphere", ".ply",
         ["--flow", "bilateral_normal", "--iterations", "4", "--ridges"]),
        ("mcf, adaptive ring1, fixed vertices", "builtin:noisy-sphere", ".stl",
         ["--flow", "mcf", "--iterations", "8", "--adaptive", "ring1", "--fixed", fixed]),
        ("survey coordinates, the default job", survey, ".ply", []),
        ("survey coordinates, laplacian, to float32 STL", survey, ".stl",
         ["--flow", "laplacian", "--iterations", "5"]),
        ("texture coordinates, normals and materials", attributes, ".obj", ["--flow", "taubin", "--iterations", "10"]),
        ("colours and a property as the strength", colours, ".ply",
         ["--flow", "bilaplacian", "--iterations", "6", "--weight", "quality"]),
        ("repeated positions welded, a degenerate face", welded, ".ply", ["--flow", "laplacian", "--iterations", "5"]),
    ]
    bunny = shared_file(a.shared, "meshes", "stanford-bunny.ply")
    if bunny:
        cases.append(("the bunny, the default job", bunny, ".ply", []))

    with Server(a.server, "--quiet") as server:
        def same_bits(name, source, ext, flags):
            outs, summaries = [], []
            for where, extra in (("local", []), ("service", ["--server", server.address, "--retries", "0"])):
                out = os.path.join(tmp, f"{name.replace(' ', '_').replace(',', '')}.{where}{ext}")
                r = run([a.cli, "smooth", source, "-o", out, "--json", *flags, *extra])
                assert r.returncode == 0, (where, r.returncode, r.stderr)
                with open(out, "rb") as f:
                    outs.append(f.read())
                summaries.append(summary_without_run(r.stdout))
            assert outs[0] == outs[1], f"{name}: the local output differs from the service's ({len(outs[0])} and " \
                                       f"{len(outs[1])} bytes)"
            (local, local_bytes), (service, service_bytes) = summaries
            assert local == service, (name, local, service)
            # In memory there are no result bytes; the service sends Draco bytes.
            assert local_bytes == 0 and service_bytes > 0, (local_bytes, service_bytes)

        for name, source, ext, flags in cases:
            check(f"same bits locally and through meshsmoothd: {name}", same_bits, name, source, ext, flags)

        def same_errors():
            for flags, message in (
                    (["--iterations", "20000"],
                     "meshsmooth: INVALID_ARGUMENT: iterations 20000 is above this server's limit of 10000\n"),
                    (["--timeout", "0.3", "--flow", "taubin", "--iterations", "10000"],
                     "meshsmooth: DEADLINE_EXCEEDED: Deadline Exceeded\n")):
                for extra in ([], ["--server", server.address, "--retries", "0"]):
                    out = os.path.join(tmp, "refused.ply")
                    r = run([a.cli, "smooth", "builtin:noisy-sphere-large", "-o", out, "-q", *flags, *extra])
                    assert (r.returncode, r.stderr) == (1, message), (flags, extra, r.returncode, r.stderr)
                    assert not os.path.exists(out), flags
        check("a job's errors read the same locally and through meshsmoothd (the iteration limit, the deadline)",
              same_errors)

    def ctrl_c_stops_a_local_job():
        out = os.path.join(tmp, "never.ply")
        err = interrupt_long_job([a.cli, "smooth", "builtin:noisy-sphere-large", "-o", out, "--flow", "taubin",
                                  "--iterations", "10000"], out)
        assert "meshsmooth: interrupted; the job was cancelled" in err, err
    check("Ctrl-C stops a local job and exits 130", ctrl_c_stops_a_local_job)


def main():
    ap = parser(__doc__, required=("cli", "server"), optional=("shared",))
    a = ap.parse_args()
    return run_checks(lambda checks, tmp: local_run_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-local-")


if __name__ == "__main__":
    sys.exit(main())
