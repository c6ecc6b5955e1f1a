#!/usr/bin/python3
"""The Python package meshsmooth (python/), imported by /usr/bin/python3 from the build's package
folder (ctest sets PYTHONPATH), against the CLI and a real meshsmoothd with TLS and a token:

- the bunny smoothed in this process and through meshsmoothd: the same positions as the CLI
  writes for the same job, both ways; the summary a dataclass;
- survey coordinates in double with a per-vertex strength: the CLI's positions again, and the
  vertices of strength 0 exactly as given;
- a bad parameter raises meshsmooth.Error with INVALID_ARGUMENT and the parameter's name
  (checked here, and by the server); a wrong token UNAUTHENTICATED;
- the GIL is released while a job runs; Ctrl-C in the middle of a long job raises
  KeyboardInterrupt within seconds and the server logs the job CANCELLED (and a local job
  stops too);
- Open3D (python3-open3d; a skip without it): smooth_open3d keeps the vertex colours exactly.

Run by ctest: package_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd [--shared DIR]
Prints one line per check and ends with 'N passed, M failed'.
"""
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np

from harness import Server, parser, require, run, run_checks, shared_file, write_text
from local_run_test import icosphere
from tls_test import make_ca, make_server_cert

import meshsmooth

TOKEN = "python-package-test-token"
JOB = dict(flow="taubin", iterations=10)
CLI_JOB = ["--flow", "taubin", "--iterations", "10"]


def load_bunny(shared):
    """(vertices, faces) of the Stanford bunny (ASCII PLY in shared/data/meshes), or of a noisy
    icosphere when the shared folder is absent."""
    path = shared_file(shared, "meshes", "stanford-bunny.ply")
    if not path:
        print("note: a noisy icosphere stands in for the bunny", flush=True)
        v, f = icosphere(4)
        rng = np.random.default_rng(1)
        return np.asarray(v) + rng.uniform(-0.01, 0.01, (len(v), 3)), np.asarray(f, dtype=np.int64)
    with open(path) as fh:
        lines = fh.read().splitlines()
    end = lines.index("end_header")
    counts = {w[1]: int(w[2]) for w in (line.split() for line in lines[:end]) if w[0] == "element"}
    nv, nf = counts["vertex"], counts["face"]
    vertices = np.array([line.split()[:3] for line in lines[end + 1:end + 1 + nv]], dtype=np.float64)
    faces = np.array([line.split()[1:4] for line in lines[end + 1 + nv:end + 1 + nv + nf]], dtype=np.int64)
    return vertices, faces


def write_ply(path, vertices, faces, weight=None):
    """An ASCII PLY with double coordinates (and a float property `w` when given)."""
    header = ["ply", "format ascii 1.0", f"element vertex {len(vertices)}", "property double x",
              "property double y", "property double z"]
    if weight is not None:
        header.append("property float w")
    header += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    rows = [" ".join(repr(float(c)) for c in p) + ("" if weight is None else f" {weight[i]!r}")
            for i, p in enumerate(vertices)]
    rows += [f"3 {a} {b} {c}" for a, b, c in faces]
    write_text(path, "\n".join(header + rows) + "\n")


def obj_vertices(path):
    """The `v` lines of an OBJ file (the CLI writes each double exactly)."""
    with open(path) as fh:
        return np.array([line.split()[1:4] for line in fh if line.startswith("v ")], dtype=np.float64)


def cli_smooth(cli, source, out, *flags):
    r = run([cli, "smooth", source, "-o", out, "-q", *CLI_JOB, *flags], timeout=300)
    require(r.returncode == 0, f"the CLI failed ({r.returncode}): {r.stderr}")
    return obj_vertices(out)


def expect_error(code, words, **kwargs):
    """meshsmooth.smooth(**kwargs) must raise meshsmooth.Error with `code` and every one of `words`
    in its message."""
    try:
        meshsmooth.smooth(**kwargs)
    except meshsmooth.Error as e:
        require(e.code == code and all(w in e.message for w in words), f"{e.code}: {e.message}")
        return e
    raise AssertionError(f"no meshsmooth.Error for {sorted(kwargs)}")


CHILD = r"""
import signal, sys, numpy as np, meshsmooth
# Ctrl-C as an interactive python3 takes it, also when this test was started with SIGINT ignored.
signal.signal(signal.SIGINT, signal.default_int_handler)
mesh = np.load(sys.argv[1])
started = False
def progress(p):
    global started
    if not started:
        started = True
        print("started", type(p).__name__, flush=True)
server = dict(server=sys.argv[2], tls_ca=sys.argv[3], token_file=sys.argv[4]) if len(sys.argv) > 2 else {}
try:
    meshsmooth.smooth(mesh["v"], mesh["f"], flow="taubin", iterations=10000, progress=progress, **server)
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(130)
print("finished", flush=True)
"""


def interrupt_child(tmp, *server_args):
    """A child python3 smoothing a large sphere with 10000 taubin iterations, sent SIGINT once its
    first progress came: it must print 'interrupted' and exit 130 within 5 s."""
    path = os.path.join(tmp, "large.npz")
    if not os.path.exists(path):
        v, f = icosphere(6)
        rng = np.random.default_rng(2)
        np.savez(path, v=np.asarray(v) + rng.uniform(-0.002, 0.002, (len(v), 3)), f=np.asarray(f))
    p = subprocess.Popen([sys.executable, "-c", CHILD, path, *server_args], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    first = p.stdout.readline().strip()
    if first != "started Progress":
        p.kill()
        raise AssertionError(f"the child's first line: {first!r}; stderr: {p.communicate()[1]}")
    time.sleep(0.5)
    p.send_signal(signal.SIGINT)
    t0 = time.time()
    out, err = p.communicate(timeout=15)
    require(p.returncode == 130 and "interrupted" in out, (p.returncode, out, err))
    require(time.time() - t0 < 5, f"the job took {time.time() - t0:.1f} s to stop")


def package_checks(a, check, tmp):
    check(f"meshsmooth is imported from the build ({os.path.dirname(meshsmooth.__file__)})", lambda: None)
    vertices, faces = load_bunny(a.shared)
    bunny = os.path.join(tmp, "bunny.ply")
    write_ply(bunny, vertices, faces)

    def local_like_the_cli():
        result = meshsmooth.smooth(vertices, faces, **JOB)
        expected = cli_smooth(a.cli, bunny, os.path.join(tmp, "cli-local.obj"))
        require(result.vertices.dtype == np.float64 and result.vertices.shape == vertices.shape, result.vertices.shape)
        require(np.array_equal(result.vertices, expected), "positions differ from the CLI's")
        require(np.array_equal(result.faces, faces), "faces differ from the input's")
        require(not np.array_equal(result.vertices, vertices), "nothing moved")
        s = result.summary
        require(isinstance(s, meshsmooth.Summary) and s.parameters["flow"] == "taubin"
                and s.parameters["iterations_run"] == 10 and s.after["area"] > 0, s)
        return result
    local = check(f"the bunny ({len(vertices)} vertices) smoothed in this process: the CLI's positions, exactly",
                  local_like_the_cli)

    def survey_with_strength():
        origin = np.array([500123.4567, 4100456.789, 312.25])
        survey = vertices * 100.0 + origin
        weight = (vertices[:, 0] > np.median(vertices[:, 0])).astype(np.float32)
        path = os.path.join(tmp, "survey.ply")
        write_ply(path, survey, faces, weight)
        result = meshsmooth.smooth(survey, faces, strength=weight, **JOB)
        expected = cli_smooth(a.cli, path, os.path.join(tmp, "cli-survey.obj"), "--weight", "w")
        require(np.array_equal(result.vertices, expected), "positions differ from the CLI's")
        held = weight == 0
        require(np.array_equal(result.vertices[held], survey[held]), "a vertex of strength 0 moved")
        require(not np.array_equal(result.vertices[~held], survey[~held]), "nothing moved")
    check("survey coordinates with a per-vertex strength: the CLI's positions; strength 0 keeps a vertex exactly",
          survey_with_strength)

    def enhanced_like_the_cli():
        result = meshsmooth.enhance(vertices, faces, gain=2.5, detail="6h", smooth_first=True)
        out = os.path.join(tmp, "cli-enhanced.obj")
        r = run([a.cli, "enhance", bunny, "-o", out, "-q", "--gain", "2.5", "--detail", "6h", "--smooth-first"],
                timeout=300)
        require(r.returncode == 0, f"the CLI failed ({r.returncode}): {r.stderr}")
        require(np.array_equal(result.vertices, obj_vertices(out)), "positions differ from the CLI's")
        e = result.summary.parameters["enhance"]
        require(e["gain"] == 2.5 and abs(e["detail_scale_h"] - 6) < 1e-9 and e["smooth_first"], e)
        return result
    enhanced = check("the bunny enhanced in this process (smoothed first, gain 2.5): the CLI's positions, exactly",
                     enhanced_like_the_cli)

    def enhance_refused(code, words, **kwargs):
        try:
            meshsmooth.enhance(**dict(dict(vertices=vertices, faces=faces), **kwargs))
        except meshsmooth.Error as e:
            require(e.code == code and all(w in e.message for w in words), f"{e.code}: {e.message}")
            return
        raise AssertionError("no meshsmooth.Error")
    check("enhance(gain=1) raises INVALID_ARGUMENT naming enhance.gain",
          enhance_refused, "INVALID_ARGUMENT", ["enhance.gain"], gain=1.0)
    edges = np.linalg.norm(vertices[faces[:, 0]] - vertices[faces[:, 1]], axis=1).mean()
    noisy = vertices + np.random.default_rng(1).normal(scale=0.3 * edges, size=vertices.shape)
    check("enhance() of the bunny with noise of 0.3 edge lengths, without smooth_first, raises FAILED_PRECONDITION: "
          "the input is noisy", enhance_refused, "FAILED_PRECONDITION", ["the input is noisy"], vertices=noisy)

    def gil_released():
        gaps, done = [], threading.Event()
        worker = threading.Thread(target=lambda: (meshsmooth.smooth(vertices, faces, flow="taubin", iterations=300),
                                                  done.set()))
        t0 = last = time.time()
        worker.start()
        while not done.is_set() and time.time() - t0 < 120:
            now = time.time()
            gaps.append(now - last)
            last = now
        worker.join()
        require(done.is_set(), "the job did not end")
        require(time.time() - t0 > 0.2 and max(gaps) < 0.2,
                f"the job took {time.time() - t0:.2f} s; the longest pause of this thread {max(gaps):.3f} s")
    check("the GIL is released while a job runs: another thread keeps running", gil_released)

    check("a bad parameter (step=-1) raises meshsmooth.Error with INVALID_ARGUMENT naming step",
          expect_error, "INVALID_ARGUMENT", ["step"], vertices=vertices, faces=faces, step=-1.0)
    check("an unknown boundary mode raises INVALID_ARGUMENT naming boundary",
          expect_error, "INVALID_ARGUMENT", ["boundary"], vertices=vertices, faces=faces, boundary="loose")
    check("a parameter of the wrong type raises INVALID_ARGUMENT naming it",
          expect_error, "INVALID_ARGUMENT", ["tolerance"], vertices=vertices, faces=faces, tolerance="small")

    def certificates():
        ca = make_ca(tmp, "ca")
        return ca[0], make_server_cert(tmp, *ca)
    made = check("a CA and a server certificate it signed (openssl)", certificates)
    if made is None:
        return
    ca, (cert, key) = made
    token = write_text(os.path.join(tmp, "token"), TOKEN + "\n")
    wrong = write_text(os.path.join(tmp, "wrong-token"), "not-the-token\n")
    with Server(a.server, "--tls-cert", cert, "--tls-key", key, "--auth-token-file", token,
                stderr=Server.KEEP) as server:
        remote = dict(server=server.address, tls_ca=ca, token_file=token, timeout=120)

        def remote_like_the_cli():
            result = meshsmooth.smooth(vertices, faces, **JOB, **remote)
            expected = cli_smooth(a.cli, bunny, os.path.join(tmp, "cli-remote.obj"), "--server", server.address,
                                  "--tls-ca", ca, "--token-file", token)
            require(np.array_equal(result.vertices, expected), "positions differ from the CLI's")
            if local is not None:
                require(np.array_equal(result.vertices, local.vertices), "positions differ from the local run's")
            require(result.summary.result_bytes > 0 and result.summary.job_id, result.summary)
        check("the bunny through meshsmoothd (TLS, a token): the CLI's positions, and the local run's",
              remote_like_the_cli)

        def remote_enhanced():
            result = meshsmooth.enhance(vertices, faces, gain=2.5, detail="6h", smooth_first=True, **remote)
            if enhanced is not None:
                require(np.array_equal(result.vertices, enhanced.vertices), "positions differ from the local run's")
            require(result.summary.parameters["enhance"]["gain"] == 2.5, result.summary.parameters)
        check("the bunny enhanced through meshsmoothd: the local run's positions", remote_enhanced)

        check("the server's own refusal: iterations above its limit raise INVALID_ARGUMENT naming iterations",
              expect_error, "INVALID_ARGUMENT", ["iterations", "limit"], vertices=vertices, faces=faces,
              iterations=20000, **remote)
        check("a wrong token raises UNAUTHENTICATED", expect_error, "UNAUTHENTICATED", [], vertices=vertices,
              faces=faces, **JOB, **dict(remote, token_file=wrong, retries=0))

        def ctrl_c_cancels_on_the_server():
            before = len(server.job_lines())
            interrupt_child(tmp, server.address, ca, token)
            deadline = time.time() + 5
            while time.time() < deadline and len(server.job_lines()) == before:
                time.sleep(0.1)
            statuses = [status for _, status in server.job_lines()[before:]]
            require(statuses == ["CANCELLED"], f"the server logged {statuses}")
        check("Ctrl-C in the middle of a long job: KeyboardInterrupt within 5 s, the server logs it CANCELLED",
              ctrl_c_cancels_on_the_server)

    check("Ctrl-C in the middle of a long job in this process: KeyboardInterrupt within 5 s",
          interrupt_child, tmp)

    def open3d_colours():
        try:
            import open3d as o3d
        except ImportError:
            print("skip: no Open3D (apt-get install python3-open3d)", flush=True)
            return
        rng = np.random.default_rng(3)
        colours = rng.random((len(vertices), 3))
        mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices),
                                         o3d.utility.Vector3iVector(faces.astype(np.int32)))
        mesh.vertex_colors = o3d.utility.Vector3dVector(colours)
        mesh.compute_vertex_normals()
        out = meshsmooth.smooth_open3d(mesh, **JOB)
        require(isinstance(out, o3d.geometry.TriangleMesh), type(out))
        require(np.array_equal(np.asarray(out.vertex_colors), colours), "the colours changed")
        if local is not None:
            require(np.array_equal(np.asarray(out.vertices), local.vertices), "positions differ from smooth()'s")
        normals = np.asarray(out.vertex_normals)
        used = np.zeros(len(vertices), dtype=bool)
        used[faces.ravel()] = True  # the bunny has vertices no face uses: their normal is 0, as Open3D's
        require(normals.shape == vertices.shape and np.allclose(np.linalg.norm(normals[used], axis=1), 1.0)
                and not normals[~used].any(), "the normals are not unit vectors (0 where no face is)")
        require(not np.allclose(normals, np.asarray(mesh.vertex_normals)), "the normals were not recomputed")
    check("Open3D: smooth_open3d returns a TriangleMesh with the colours exactly and fresh normals", open3d_colours)


def main():
    a = parser(__doc__, required=("cli", "server"), optional=("shared",)).parse_args()
    return run_checks(lambda checks, tmp: package_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-python-")


if __name__ == "__main__":
    sys.exit(main())
