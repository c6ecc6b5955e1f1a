#!/usr/bin/python3
"""A local run (no --server) is bounded by the machine's memory, not by a network service's
limits; a job's memory is estimated before it runs and a job above the bound is refused naming
both figures, by the CLI's local run (--max-memory) and by meshsmoothd's admission
(--max-job-bytes) at the head of the upload. A quantized upload (--quantize-upload, smooth's and
submit's) fits a service's upload limit that the lossless one exceeds, and states its bound.

Input: a noisy height field of 141 x 141 = 19,881 vertices written here as binary PLY (its
lossless Draco upload is ~0.7 MB).

Run by ctest: local_limits_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd
Prints one line per check and ends with 'N passed, M failed'.
"""
import math
import os
import random
import re
import struct
import sys
import urllib.request

from harness import Server, metric_sum, parse_metrics, parser, ply_counts, run, run_checks

SIDE = 141  # vertices a side: 19,881 in all


def clean_height(x, y):
    return 0.5 * math.sin(x / 9.0) * math.cos(y / 11.0)


def write_noisy_height_field(path, seed=1):
    """A SIDE x SIDE grid of unit spacing over clean_height, z noise uniform in +-0.15, binary PLY."""
    rng = random.Random(seed)
    vertices = [(x, y, clean_height(x, y) + rng.uniform(-0.15, 0.15)) for y in range(SIDE) for x in range(SIDE)]
    faces = []
    for y in range(SIDE - 1):
        for x in range(SIDE - 1):
            a = y * SIDE + x
            faces += [(a, a + 1, a + SIDE + 1), (a, a + SIDE + 1, a + SIDE)]
    with open(path, "wb") as f:
        f.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(vertices)}\nproperty float x\n"
                 f"property float y\nproperty float z\nelement face {len(faces)}\n"
                 "property list uchar int vertex_indices\nend_header\n").encode())
        for v in vertices:
            f.write(struct.pack("<3f", *v))
        for t in faces:
            f.write(struct.pack("<B3i", 3, *t))
    return len(vertices), len(faces)


def read_binary_ply_vertices(path):
    """The (x, y, z) of a binary little-endian PLY whose vertices are float or double x, y, z first."""
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline().decode("ascii").strip()
            header.append(line)
            if line == "end_header":
                break
        n = next(int(w.split()[2]) for w in header if w.startswith("element vertex"))
        props = []
        in_vertex = False
        for w in header:
            if w.startswith("element"):
                in_vertex = w.startswith("element vertex")
            elif w.startswith("property") and in_vertex:
                props.append(w.split()[1])
        assert "binary_little_endian" in header[1], header[1]
        assert all(p in ("float", "double") for p in props), props
        fmt = "<" + "".join("f" if p == "float" else "d" for p in props)
        size = struct.calcsize(fmt)
        return [struct.unpack(fmt, f.read(size))[:3] for _ in range(n)]


def rms_to_clean(points):
    return math.sqrt(sum((z - clean_height(x, y)) ** 2 for x, y, z in points) / len(points))


def estimate_figures(stderr):
    """(needed, bound, vertices, faces) from a refusal 'needs about 72 MB (71659014 bytes) of memory,
    estimated for V vertices, F faces, ..., above ... 2 MB (2000000 bytes)'."""
    m = re.search(r"needs about (?:[0-9.]+ [MG]B \()?(\d+) bytes\)? of memory, estimated for (\d+) vertices, "
                  r"(\d+) faces", stderr)
    assert m is not None, stderr
    bound = re.search(r"above (?:this server's limit of |the )(?:[0-9.]+ [MG]B \()?(\d+) bytes", stderr)
    assert bound is not None, stderr
    return int(m.group(1)), int(bound.group(1)), int(m.group(2)), int(m.group(3))


def local_limits_checks(a, check, tmp):
    mesh = os.path.join(tmp, "height-field.ply")
    vertices, faces = write_noisy_height_field(mesh)
    noisy_rms = rms_to_clean(read_binary_ply_vertices(mesh))

    with Server(a.server, "--quiet", "--max-upload-bytes", "100000") as small:
        def the_service_refuses_the_upload():
            out = os.path.join(tmp, "service.ply")
            r = run([a.cli, "smooth", mesh, "-o", out, "--server", small.address, "--retries", "0", "-q"])
            assert r.returncode == 1, (r.returncode, r.stderr)
            assert "RESOURCE_EXHAUSTED" in r.stderr and "100000 bytes (--max-upload-bytes)" in r.stderr, r.stderr
            assert not os.path.exists(out)
        check("meshsmoothd with a 100 kB upload limit refuses the 19,881-vertex mesh",
              the_service_refuses_the_upload)

    def the_local_run_smooths_it():
        out = os.path.join(tmp, "local.ply")
        r = run([a.cli, "smooth", mesh, "-o", out, "-q"])
        assert r.returncode == 0, (r.returncode, r.stderr)
        assert ply_counts(out) == (vertices, faces), ply_counts(out)
        smoothed_rms = rms_to_clean(read_binary_ply_vertices(out))
        assert smoothed_rms < 0.5 * noisy_rms, (smoothed_rms, noisy_rms)
    check("the local run smooths it: every vertex back, under half the noisy input's distance to the clean surface",
          the_local_run_smooths_it)

    local = {}

    def the_local_run_refuses_above_max_memory():
        out = os.path.join(tmp, "refused-local.ply")
        r = run([a.cli, "smooth", mesh, "-o", out, "--max-memory", "1000000"])
        assert r.returncode == 1, (r.returncode, r.stderr)
        needed, bound, v, f = estimate_figures(r.stderr)
        assert (bound, v, f) == (1000000, vertices, faces), (bound, v, f)
        assert needed > bound, (needed, bound)
        assert "--max-memory" in r.stderr, r.stderr
        assert not os.path.exists(out)
        local["needed"] = needed
    check("the local run refuses a job whose estimate is above --max-memory, naming both figures",
          the_local_run_refuses_above_max_memory)

    def the_local_run_names_available_memory():
        # A bound above the estimate lets the same job run.
        out = os.path.join(tmp, "allowed-local.ply")
        r = run([a.cli, "smooth", mesh, "-o", out, "-q", "--max-memory", str(local.get("needed", 10 ** 9))])
        assert r.returncode == 0, (r.returncode, r.stderr)
        assert ply_counts(out) == (vertices, faces)
    check("the same job runs with --max-memory at its estimate", the_local_run_names_available_memory)

    with Server(a.server, "--quiet", "--max-upload-bytes", "300000", "--job-store",
                os.path.join(tmp, "store")) as limited:
        def check_quantized_bound(text, fraction):
            """The CLI's line on a quantized upload: its bits, and a bound of at most `fraction` mean edges."""
            m = re.search(r"^upload quantized to (\d+) bits: each coordinate within ([0-9.e+-]+) of the input "
                          rf"\({re.escape(fraction)} of the mean edge ([0-9.e+-]+)\)$", text, re.M)
            assert m is not None, text
            bits, bound, mean_edge = int(m.group(1)), float(m.group(2)), float(m.group(3))
            # Two legs of 1 and a diagonal of about sqrt 2 a cell, lengthened a little by the waves and the noise.
            assert 1.13 < mean_edge < 1.3, mean_edge
            assert 0 < bound <= float(fraction) * mean_edge and 1 <= bits <= 24, (bits, bound, mean_edge)

        def a_quantized_upload_fits_where_the_lossless_one_does_not():
            lossless = run([a.cli, "smooth", mesh, "-o", os.path.join(tmp, "lossless.ply"), "--server",
                            limited.address, "--retries", "0", "-q"])
            assert lossless.returncode == 1 and "--max-upload-bytes" in lossless.stderr, lossless.stderr
            out = os.path.join(tmp, "quantized.ply")
            r = run([a.cli, "smooth", mesh, "-o", out, "--server", limited.address, "--retries", "0",
                     "--quantize-upload"])
            assert r.returncode == 0, (r.returncode, r.stderr)
            check_quantized_bound(r.stdout, "0.001")
            assert ply_counts(out) == (vertices, faces)
            assert rms_to_clean(read_binary_ply_vertices(out)) < 0.5 * noisy_rms
        check("--quantize-upload sends the mesh under a 300 kB upload limit that refuses the lossless upload, and "
              "the summary states the bound (at most 0.001 mean edges) and the bits",
              a_quantized_upload_fits_where_the_lossless_one_does_not)

        def a_quantized_submit_fits_and_states_its_bound():
            lossless = run([a.cli, "submit", mesh, "--server", limited.address, "--retries", "0"])
            assert lossless.returncode == 1 and "--max-upload-bytes" in lossless.stderr, lossless.stderr
            out = os.path.join(tmp, "submitted.drc")
            r = run([a.cli, "submit", mesh, "--server", limited.address, "--retries", "0",
                     "--quantize-upload=0.002", "--wait", "-o", out])
            assert r.returncode == 0, (r.returncode, r.stderr)
            check_quantized_bound(r.stderr, "0.002")
            # stdout is the job's id alone (then the watch's lines), as without the flag.
            job_id = r.stdout.splitlines()[0]
            assert re.fullmatch(r"[0-9a-f-]+", job_id), r.stdout
            assert os.path.getsize(out) > 0
            info = run([a.cli, "info", out])
            assert info.returncode == 0 and re.search(rf"^vertices: {vertices}$", info.stdout, re.M), info.stdout
        check("submit --quantize-upload=0.002 sends the job under a 300 kB upload limit that refuses the lossless "
              "one, states the bound (at most 0.002 mean edges) on stderr, and the job succeeds",
              a_quantized_submit_fits_and_states_its_bound)

        def a_bad_fraction_is_refused():
            for bad in ("0", "-0.5", "nan", "0.2"):
                r = run([a.cli, "smooth", mesh, "-o", os.path.join(tmp, "bad.ply"), "--server", limited.address,
                         f"--quantize-upload={bad}"])
                assert r.returncode == 2, (bad, r.returncode, r.stderr)
                assert ("--quantize-upload takes the bound as a fraction of the mean edge length, above 0 and at "
                        f"most 0.1 (default 0.001 when given alone); got '{bad}'") in r.stderr, r.stderr
            r = run([a.cli, "submit", mesh, "--server", limited.address, "--quantize-upload=0.2"])
            assert r.returncode == 2 and "--quantize-upload takes the bound as a fraction" in r.stderr, r.stderr
            r = run([a.cli, "smooth", mesh, "-o", os.path.join(tmp, "bad.ply"), "--quantize-upload"])
            assert r.returncode == 2 and "--quantize-upload quantizes what is sent to --server" in r.stderr, r.stderr
            assert not os.path.exists(os.path.join(tmp, "bad.ply"))
        check("--quantize-upload refuses 0, a negative value, NaN and 0.2 (smooth and submit), and a run without "
              "--server (exit 2)",
              a_bad_fraction_is_refused)

    with Server(a.server, "--quiet", "--max-job-bytes", "2000000", "--metrics-listen", "127.0.0.1:0") as bounded:
        def the_service_refuses_at_the_head_of_the_upload():
            out = os.path.join(tmp, "refused-service.ply")
            r = run([a.cli, "smooth", mesh, "-o", out, "--server", bounded.address, "--retries", "3"])
            assert r.returncode == 1, (r.returncode, r.stderr)
            assert "RESOURCE_EXHAUSTED" in r.stderr and "--max-job-bytes" in r.stderr, r.stderr
            needed, bound, v, f = estimate_figures(r.stderr)
            assert (bound, v, f) == (2000000, vertices, faces), (bound, v, f)
            # The same model as the local run's, on the same counts.
            assert needed == local.get("needed"), (needed, local)
            assert not os.path.exists(out)
            with urllib.request.urlopen(f"http://{bounded.metrics_address}/metrics", timeout=10) as page:
                samples = parse_metrics(page.read().decode())
            # A permanent refusal: not retried, counted once, and no job ran.
            assert metric_sum(samples, "meshsmooth_refusals_total", reason="job_too_large") == 1, samples
            assert metric_sum(samples, "meshsmooth_jobs_total") == 0
        check("meshsmoothd refuses a job whose estimate is above --max-job-bytes at its first chunk, naming both "
              "figures, without retries", the_service_refuses_at_the_head_of_the_upload)


def main():
    ap = parser(__doc__, required=("cli", "server"))
    a = ap.parse_args()
    return run_checks(lambda checks, tmp: local_limits_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-limits-")


if __name__ == "__main__":
    sys.exit(main())
