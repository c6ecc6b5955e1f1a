#!/usr/bin/python3
"""The time-to-quality programs as a user runs them: meshsmooth_peer (each peer of the build
brings a noisy sphere closer to the sphere, its line, its exit codes; meshsmooth_peer_LIBRARY
beside it runs that library's peers and no other's) and
meshsmooth_time_to_quality (help, argument errors, and a whole run on the benchmark's synthetic
sphere, whose table must show the default job and a peer below the noisy input's distance).

Run by ctest: time_to_quality_test.py --peer build/bench/meshsmooth_peer
    --time-to-quality build/bench/meshsmooth_time_to_quality --quality build/bench/meshsmooth_quality
    --cli build/client/meshsmooth
Prints one line per check and ends with 'N passed, M failed'.
"""
import math
import os
import re
import sys

# The harness the Python tests share, tests/python/harness.py.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
from harness import parser, ply_counts, require, run, run_checks  # noqa: E402

# Peers that move vertices along the surface only: they need not bring a noisy sphere closer.
TANGENTIAL = {"cgal_tangential_relaxation"}
SIGMA = 0.3  # noise of the test sphere, in mean edge lengths
ITERATIONS = 3


def read_obj(path):
    """(positions, triangles) of an OBJ file of `v x y z` and `f a b c` lines."""
    positions, triangles = [], []
    with open(path) as f:
        for line in f:
            words = line.split()
            if words[:1] == ["v"]:
                positions.append(tuple(float(w) for w in words[1:4]))
            elif words[:1] == ["f"]:
                triangles.append(tuple(int(w.split("/")[0]) - 1 for w in words[1:4]))
    return positions, triangles


def mean_edge(positions, triangles):
    edges = {tuple(sorted((t[i], t[(i + 1) % 3]))) for t in triangles for i in range(3)}
    return sum(math.dist(positions[a], positions[b]) for a, b in edges) / len(edges)


def rms_to_unit_sphere(positions, h):
    """RMS distance of the vertices to the unit sphere (the clean icosphere's vertices lie on
    it), in mean edge lengths h."""
    return math.sqrt(sum((math.hypot(*p) - 1.0) ** 2 for p in positions) / len(positions)) / h


def peers_of(peer):
    """The peer names `meshsmooth_peer --help` lists for this build."""
    r = run([peer, "--help"])
    require(r.returncode == 0, f"--help exited {r.returncode}: {r.stderr}")
    lines = r.stdout.split("PEER, in this program:\n", 1)
    require(len(lines) == 2, f"no peer list in --help:\n{r.stdout}")
    return [line.split()[0] for line in lines[1].splitlines() if line.startswith("  ")]


def main():
    ap = parser(__doc__, required=["cli"])
    ap.add_argument("--peer", required=True, help="the meshsmooth_peer binary")
    ap.add_argument("--time-to-quality", required=True, help="the meshsmooth_time_to_quality binary")
    ap.add_argument("--quality", required=True, help="the meshsmooth_quality binary (writes the noisy sphere)")
    args = ap.parse_args()

    def body(checks, tmp):
        noisy = os.path.join(tmp, "noisy.obj")
        r = run([args.quality, "--write-noisy", "sphere", str(SIGMA), "1", noisy])
        require(r.returncode == 0, f"meshsmooth_quality --write-noisy failed: {r.stderr}")
        positions, triangles = read_obj(noisy)
        h = mean_edge(positions, triangles)
        noisy_rms = rms_to_unit_sphere(positions, h)

        def listed():
            names = peers_of(args.peer)
            require({"openmesh_c0", "openmesh_c1"} <= set(names), f"peers {names}")
            return names

        peers = checks.check("peer: --help lists the peers, OpenMesh's among them", listed)

        def smooths(name):
            out = os.path.join(tmp, f"{name}.obj")
            r = run([args.peer, name, str(ITERATIONS), noisy, out])
            require(r.returncode == 0, f"exit {r.returncode}: {r.stderr}")
            require(re.fullmatch(rf"{name}: {ITERATIONS} iterations; time: read [0-9.]+s, smooth [0-9.]+s, "
                                 r"write [0-9.]+s\n", r.stdout), f"unexpected line {r.stdout!r}")
            result, result_triangles = read_obj(out)
            require(result_triangles == triangles, "the faces changed")
            require(len(result) == len(positions), f"{len(result)} vertices, not {len(positions)}")
            require(all(math.isfinite(c) for p in result for c in p), "a coordinate is not finite")
            require(result != positions, "no vertex moved")
            rms = rms_to_unit_sphere(result, h)
            if name not in TANGENTIAL:
                require(rms < 0.7 * noisy_rms, f"RMS to the sphere {rms:.4f} h, noisy {noisy_rms:.4f} h")

        for name in peers or []:
            checks.check(f"peer: {name} brings the noisy sphere closer (or moves it, if tangential)", smooths, name)

        def one_library_each():
            folder = os.path.dirname(os.path.abspath(args.peer))
            seen = []
            for library in ("openmesh", "open3d", "cgal"):
                program = os.path.join(folder, f"meshsmooth_peer_{library}")
                if not os.path.exists(program):
                    require(not any(p.startswith(library + "_") for p in peers), f"no {program}")
                    continue
                names = peers_of(program)
                require(names and all(n.startswith(library + "_") for n in names), f"{program} runs {names}")
                seen += names
                out = os.path.join(tmp, f"{library}.obj")
                r = run([program, names[0], "1", noisy, out])
                require(r.returncode == 0 and os.path.exists(out), f"{program} {names[0]}: {r.stderr}")
            require(seen == peers, f"the per-library programs run {seen}, meshsmooth_peer {peers}")

        checks.check("peer: each meshsmooth_peer_LIBRARY runs its own library's peers, together all of them",
                     one_library_each)

        def writes_ply():
            out = os.path.join(tmp, "out.ply")
            r = run([args.peer, "openmesh_c0", "2", noisy, out])
            require(r.returncode == 0, f"exit {r.returncode}: {r.stderr}")
            require(ply_counts(out) == (len(positions), len(triangles)), f"PLY counts {ply_counts(out)}")

        checks.check("peer: writes PLY with the input's vertices and faces", writes_ply)

        def fails(cmd, code, *words):
            r = run(cmd)
            require(r.returncode == code, f"exit {r.returncode}, want {code}; stderr {r.stderr!r}")
            for w in words:
                require(w in r.stderr, f"{w!r} not in stderr {r.stderr!r}")

        missing = os.path.join(tmp, "missing.ply")
        checks.check("peer: a missing input exits 1 naming the file",
                     fails, [args.peer, "openmesh_c0", "2", missing, os.path.join(tmp, "o.ply")], 1, missing)
        checks.check("peer: an unwritable output exits 1",
                     fails, [args.peer, "openmesh_c0", "2", noisy, os.path.join(tmp, "no-dir", "o.ply")], 1)
        checks.check("peer: an unknown peer exits 2", fails,
                     [args.peer, "no_such_peer", "2", noisy, os.path.join(tmp, "o.ply")], 2, "unknown peer")
        checks.check("peer: a bad iteration count exits 2", fails,
                     [args.peer, "openmesh_c0", "-1", noisy, os.path.join(tmp, "o.ply")], 2, "ITERATIONS")
        checks.check("peer: an unknown output format exits 2", fails,
                     [args.peer, "openmesh_c0", "2", noisy, os.path.join(tmp, "o.xyz")], 2)
        checks.check("peer: too few arguments exit 2 with the usage", fails,
                     [args.peer, "openmesh_c0", "2", noisy], 2, "usage:")

        ttq = args.time_to_quality

        def helps():
            r = run([ttq, "--help"])
            require(r.returncode == 0, f"exit {r.returncode}")
            for w in ("--meshes", "--sigmas", "--runs", "--peers", "--counts", "--scale", "--cli", "oracle"):
                require(w in r.stdout, f"{w} not in --help")

        checks.check("time_to_quality: --help explains the options", helps)
        checks.check("time_to_quality: an unknown option exits 2", fails, [ttq, "--no-such-option"], 2, "usage:")
        checks.check("time_to_quality: --runs 0 exits 2", fails, [ttq, "--runs", "0"], 2, "--runs")
        checks.check("time_to_quality: a missing value exits 2", fails, [ttq, "--sigmas"], 2)
        checks.check("time_to_quality: a bad count exits 2", fails, [ttq, "--counts", "1,x"], 2, "--counts")
        checks.check("time_to_quality: a missing CLI exits 1", fails,
                     [ttq, "--cli", missing, "--meshes", "sphere"], 1, missing)
        checks.check("time_to_quality: an unknown mesh exits 1", fails,
                     [ttq, "--cli", args.cli, "--peer-program", args.peer, "--meshes", "no-such-mesh",
                      "--shared", tmp, "--runs", "1", "--peers", "openmesh_c0"], 1, "no-such-mesh")

        def whole_run():
            # No --peer-program: the benchmark finds meshsmooth_peer_openmesh beside itself.
            r = run([ttq, "--cli", args.cli, "--meshes", "sphere", "--sigmas",
                     str(SIGMA), "--runs", "1", "--counts", "1,2,3,5,8", "--peers", "openmesh_c0,no_such_peer",
                     "--workdir", os.path.join(tmp, "work")], timeout=300)
            require(r.returncode == 0, f"exit {r.returncode}: {r.stderr[-2000:]}")
            rows = {}
            for line in r.stdout.splitlines():
                cells = [c.strip() for c in line.strip("|").split("|")]
                if line.startswith("| ") and len(cells) == 7 and cells[2] not in ("RMS distance (h)", "---"):
                    rows[cells[0].split(":")[0]] = cells
            require({"noisy input", "meshsmooth default job", "chosen flow, explicit",
                     "OpenMesh JacobiLaplace uniform C0"} <= set(rows), f"rows {sorted(rows)}:\n{r.stdout}")
            noisy_row = float(rows["noisy input"][2])
            require(abs(noisy_row - SIGMA) < 0.1, f"noisy input RMS {noisy_row}")
            for name in ("meshsmooth default job", "OpenMesh JacobiLaplace uniform C0"):
                require(float(rows[name][2]) < 0.7 * noisy_row, f"{name}: RMS {rows[name][2]}, noisy {noisy_row}")
                require(float(rows[name][5]) > 0 and float(rows[name][6]) > 0, f"{name}: no time or memory")
            require(re.search(r"\(automatic\)", rows["meshsmooth default job"][1]), rows["meshsmooth default job"])
            require("(oracle" in rows["OpenMesh JacobiLaplace uniform C0"][1], "no oracle count")
            require("Ratios: default smoothing / explicit smoothing" in r.stdout, "no ratios line")
            require("Not in this build (left out): no_such_peer" in r.stdout, "the unknown peer is not named")
            # The summary's last column: the explicit run's whole process less its job's own total.
            summary = [line for line in r.stdout.splitlines() if line.startswith("| sphere |")]
            require(len(summary) == 1, f"summary rows {summary}")
            beyond_ms = float(summary[0].strip("|").split("|")[-1])
            explicit_s = float(rows["chosen flow, explicit"][5])
            require(0 < beyond_ms < 1000 * explicit_s, f"CLI beyond its job {beyond_ms} ms, process {explicit_s} s")

        checks.check("time_to_quality: a run on the noisy sphere measures the default job and a peer", whole_run)

    return run_checks(body, tmp_prefix="meshsmooth-ttq-test-")


if __name__ == "__main__":
    sys.exit(main())
