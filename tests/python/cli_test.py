#!/usr/bin/python3
"""The meshsmooth CLI as a user runs it: help, smoothing with the embedded server and through
meshsmoothd, JSON output, flows, info, exit codes, and Ctrl-C.

Run by ctest: cli_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd [--shared DIR]
Prints one line per check and ends with 'N passed, M failed'.
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

passed, failed = 0, 0


def check(name, fn):
    global passed, failed
    try:
        fn()
        passed += 1
        print(f"ok: {name}")
    except Exception as e:  # noqa: BLE001 - one failure must not hide the others
        failed += 1
        print(f"FAIL: {name}: {e}")


def run(cmd, timeout=120, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, **kw)


def ply_counts(path):
    with open(path, "rb") as f:
        header = b""
        while not header.endswith(b"end_header\n"):
            line = f.readline()
            if not line:
                raise AssertionError("truncated PLY header")
            header += line
    counts = {}
    for line in header.decode().splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0] == "element":
            counts[parts[1]] = int(parts[2])
    return counts.get("vertex"), counts.get("face")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", required=True)
    ap.add_argument("--server", required=True)
    ap.add_argument("--shared", default="")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp()
    cli = a.cli

    def help_lists_defaults():
        r = run([cli, "smooth", "--help"])
        assert r.returncode == 0, r.returncode
        for word in ("--flow", "median", "--iterations", "20", "--server", "--quantization-bits", "--json"):
            assert word in r.stdout, f"'{word}' missing from smooth --help"
        r = run([cli, "--help"])
        assert r.returncode == 0 and "Exit codes" in r.stdout and "builtin:" in r.stdout
    check("--help explains options with defaults, exit codes and built-in inputs", help_lists_defaults)

    out_ply = os.path.join(tmp, "sphere.ply")

    def embedded_smooth():
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out_ply, "--iterations", "5"])
        assert r.returncode == 0, r.stderr
        assert ply_counts(out_ply) == (2562, 5120), ply_counts(out_ply)
        assert "edge length CV" in r.stdout, r.stdout
    check("smooth with the embedded server writes the whole mesh", embedded_smooth)

    def json_summary():
        r = run([cli, "smooth", "builtin:noisy-torus", "-o", os.path.join(tmp, "t.obj"), "--flow", "taubin", "--json"])
        assert r.returncode == 0, r.stderr
        s = json.loads(r.stdout)
        assert s["parameters"]["flow"] == "taubin", s["parameters"]
        assert s["after"]["edge_length_cv"] > 0
    check("--json prints the summary as JSON", json_summary)

    def flows_json():
        r = run([cli, "flows", "--json"])
        assert r.returncode == 0, r.stderr
        names = [f["name"] for f in json.loads(r.stdout)["flows"]]
        assert names == ["laplacian", "taubin", "bilaplacian", "mcf", "mcf_tangential", "median"], names
    check("flows --json lists the six flows", flows_json)

    def bad_usage():
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out_ply, "--flow", "nope"])
        assert r.returncode == 2, r.returncode
        r = run([cli, "smooth", "/nonexistent.obj", "-o", out_ply])
        assert r.returncode == 1 and "cannot open" in r.stderr, (r.returncode, r.stderr)
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", os.path.join(tmp, "x.xyz")])
        assert r.returncode == 1 and "unknown mesh format" in r.stderr, (r.returncode, r.stderr)
    check("bad command line exits 2, bad input exits 1 with a message", bad_usage)

    def unreachable():
        r = run([cli, "smooth", "builtin:sphere", "-o", out_ply, "--server", "127.0.0.1:1", "--timeout", "5"])
        assert r.returncode == 3, (r.returncode, r.stderr)
    check("an unreachable server exits 3", unreachable)

    if a.shared and os.path.isdir(os.path.join(a.shared, "data", "meshes")):
        def info_beetle():
            r = run([cli, "info", os.path.join(a.shared, "data", "meshes", "beetle.obj")])
            assert r.returncode == 0, r.stderr
            assert "non-manifold edges: 47" in r.stdout and "non-manifold vertices: 45" in r.stdout, r.stdout
        check("info reports the beetle's non-manifold edges and vertices", info_beetle)

    server = subprocess.Popen([a.server, "--listen", "127.0.0.1:0", "--quiet"], stdout=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline()
        address = line.strip().rsplit(" ", 1)[-1]

        def through_server():
            out = os.path.join(tmp, "via_server.off")
            r = run([cli, "smooth", "builtin:noisy-plane", "-o", out, "--server", address, "--boundary", "curve"])
            assert r.returncode == 0, r.stderr
            with open(out) as f:
                assert f.readline().strip() == "OFF"
        check(f"smooth through meshsmoothd at {address}", through_server)

        def ctrl_c_cancels():
            # Taubin neither shrinks nor diverges: 10000 iterations on 40962 vertices take seconds.
            p = subprocess.Popen([cli, "smooth", "builtin:noisy-sphere-large", "-o", os.path.join(tmp, "never.ply"),
                                  "--flow", "taubin", "--iterations", "10000", "--server", address],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            time.sleep(1.5)
            p.send_signal(signal.SIGINT)
            t0 = time.time()
            _, err = p.communicate(timeout=10)
            assert p.returncode == 130, (p.returncode, err)
            assert time.time() - t0 < 5
            assert "interrupted" in err, err
            assert not os.path.exists(os.path.join(tmp, "never.ply"))
        check("Ctrl-C cancels the job and exits 130", ctrl_c_cancels)
    finally:
        server.send_signal(signal.SIGTERM)
        try:
            server.wait(timeout=15)
        except subprocess.TimeoutExpired:
            server.kill()

    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
