#!/usr/bin/python3
"""Batch runs of the meshsmooth CLI as a user runs them: 50 small meshes (one corrupt) over two
real meshsmoothd replicas with --jobs 4, each output byte for byte the one-file run's, the corrupt
file failing alone and named; --json lines, --quiet, --batch lists, the local run, the refusals
(exit 2), an unreachable server (exit 3) and Ctrl-C (exit 130).

Run by ctest: batch_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd
Prints one line per check and ends with 'N passed, M failed'.
"""
import concurrent.futures
import filecmp
import json
import os
import random
import re
import signal
import subprocess
import time

from harness import Server, free_port, parser, run, run_checks, write_text

FLOW = ["--flow", "laplacian", "--iterations", "5"]
CORRUPT = "scan_17.ply"
PEER = re.compile(r"^meshsmoothd job=(\S+) .* status=(\S+) .* peer=(\S+)")


def noisy_grid(seed, n=12):
    """(vertices, faces) of an n x n grid on the unit square, z noisy by a seeded generator."""
    rng = random.Random(seed)
    vertices = [(i / (n - 1), j / (n - 1), 0.02 * rng.uniform(-1, 1)) for j in range(n) for i in range(n)]
    faces = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            faces += [(a, a + 1, a + n + 1), (a, a + n + 1, a + n)]
    return vertices, faces


def write_ply(path, vertices, faces):
    with open(path, "w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {len(vertices)}\nproperty float x\nproperty float y\n"
                f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        f.writelines(f"{x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in vertices)
        f.writelines(f"3 {a} {b} {c}\n" for a, b, c in faces)


def write_obj(path, vertices, faces):
    with open(path, "w") as f:
        f.writelines(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in vertices)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)


def make_inputs(folder):
    """50 small noisy meshes in folder (every fifth an .obj, the rest .ply), scan_17.ply corrupt
    (its header promises more vertices than it holds). Returns their names, sorted."""
    os.makedirs(folder)
    names = []
    for k in range(50):
        name = f"scan_{k:02d}." + ("obj" if k % 5 == 0 else "ply")
        path = os.path.join(folder, name)
        if name == CORRUPT:
            write_text(path, "ply\nformat ascii 1.0\nelement vertex 144\nproperty float x\nproperty float y\n"
                             "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                             "end_header\n0 0 0\n1 0 0\n")
        elif name.endswith(".obj"):
            write_obj(path, *noisy_grid(k))
        else:
            write_ply(path, *noisy_grid(k))
        names.append(name)
    return sorted(names)


def main():
    a = parser(__doc__, required=("cli", "server")).parse_args()
    return run_checks(lambda checks, tmp: batch_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-batch-")


def batch_checks(a, check, tmp):
    cli = a.cli
    inputs = os.path.join(tmp, "in")
    names = make_inputs(inputs)
    good = [n for n in names if n != CORRUPT]

    def smooth(*args, timeout=120):
        return run([cli, "smooth", *args], timeout=timeout)

    def one_file_runs(folder, *extra):
        """Each good input smoothed on its own (4 CLIs at a time) into folder."""
        os.makedirs(folder)

        def one(name):
            r = smooth(os.path.join(inputs, name), "-o", os.path.join(folder, name), *FLOW, "-q", *extra)
            assert r.returncode == 0, (name, r.returncode, r.stderr)
        with concurrent.futures.ThreadPoolExecutor(4) as pool:
            list(pool.map(one, good))

    def same_outputs(batch_dir, single_dir):
        assert sorted(os.listdir(batch_dir)) == good, sorted(os.listdir(batch_dir))
        differ = [n for n in good if not filecmp.cmp(os.path.join(batch_dir, n), os.path.join(single_dir, n),
                                                     shallow=False)]
        assert not differ, f"outputs differ from the one-file runs: {differ}"

    one = Server(a.server, "--workers", "2", stderr=Server.KEEP)
    two = Server(a.server, "--workers", "2", stderr=Server.KEEP)
    try:
        target = f"{one.address},{two.address}"
        out = os.path.join(tmp, "out")

        def fifty_over_two_replicas():
            one_file_runs(os.path.join(tmp, "single"), "--server", one.address)
            t0 = time.monotonic()
            r = smooth(inputs, "-o", out, *FLOW, "--server", target, "--jobs", "4", "--job-id", "night")
            seconds = time.monotonic() - t0
            assert r.returncode == 1, (r.returncode, r.stderr)
            same_outputs(out, os.path.join(tmp, "single"))
            corrupt = os.path.join(inputs, CORRUPT)
            # The report: "1 of 50 files failed:" and the corrupt file alone, with its error.
            report = r.stderr[r.stderr.index("meshsmooth: 1 of 50 files failed:"):].splitlines()
            assert len(report) == 2 and report[1].startswith(f"  {corrupt}: "), report
            assert "vertex" in report[1], report  # the reader says what is wrong
            # A progress line per file on stderr, a summary line per file and a total on stdout.
            progress = re.findall(r"^\[(\d+)/50\] (\S+) (done|FAILED) \(", r.stderr, re.M)
            assert sorted(int(k) for k, _, _ in progress) == list(range(1, 51)), progress
            assert [p for _, p, state in progress if state == "FAILED"] == [corrupt], progress
            lines = r.stdout.splitlines()
            assert len(lines) == 51 and lines[-1].startswith("50 files: 49 smoothed, 1 failed"), lines[-3:]
            written = sorted(os.path.basename(m) for m in re.findall(r"^\S+ -> (\S+): laplacian, 5 of 5", r.stdout,
                                                                      re.M))
            assert written == good, written
            assert f"failed: {corrupt}: " in r.stdout, r.stdout
            print(f"  50 files over 2 replicas with --jobs 4 in {seconds:.2f} s", flush=True)
        check("50 files, --jobs 4, 2 replicas: exit 1, the 49 outputs are the one-file runs' bytes, the corrupt "
              "file fails alone, named with its error in '1 of 50 files failed'", fifty_over_two_replicas)

        def one_channel_both_replicas():
            # The replicas log a job as it ends, through their stderr pipes: wait (10 s at most) until
            # the logs hold the 49 jobs, not a fixed time, which a loaded machine can outrun.
            deadline = time.monotonic() + 10.0
            while time.monotonic() < deadline:
                logged = sum(1 for rep in (one, two) for line in rep.stderr_lines() if "job=night-" in line)
                if logged >= len(names) - 1:
                    break
                time.sleep(0.1)
            jobs = {}
            for rep in (one, two):
                peers = set()
                for line in rep.stderr_lines():
                    m = PEER.match(line)
                    if m and m.group(1).startswith("night-"):
                        jobs[m.group(1)] = m.group(2)
                        peers.add(m.group(3))
                # One channel: one connection to each replica, whatever the number of jobs.
                assert len(peers) == 1, (rep.address, peers)
            want = {f"night-{k + 1}" for k, n in enumerate(names) if n != CORRUPT}
            assert set(jobs) == want and set(jobs.values()) == {"OK"}, sorted(jobs.items())
            counts = [sum(1 for line in rep.stderr_lines() if "job=night-" in line) for rep in (one, two)]
            assert min(counts) >= 5, f"jobs per replica {counts}"
        check("the batch's jobs spread over both replicas, one connection to each, ids night-1..night-50 "
              "(the corrupt file's never sent)", one_channel_both_replicas)

        def json_lines():
            r = smooth(inputs, "-o", os.path.join(tmp, "json"), *FLOW, "--server", target, "--jobs", "4", "--json")
            assert r.returncode == 1, (r.returncode, r.stderr)
            records = [json.loads(line) for line in r.stdout.splitlines()]
            assert len(records) == 51, len(records)
            files, total = records[:-1], records[-1]
            assert sorted(os.path.basename(f["input"]) for f in files) == names
            failed = [f for f in files if not f["ok"]]
            assert [os.path.basename(f["input"]) for f in failed] == [CORRUPT], failed
            assert failed[0]["exit_code"] == 1 and failed[0]["error"], failed
            for f in files:
                if f["ok"]:
                    assert f["summary"]["parameters"]["iterations_run"] == 5, f
                    assert f["output"] == os.path.join(tmp, "json", os.path.basename(f["input"])), f
            assert total["files"] == 50 and total["succeeded"] == 49 and total["failed"] == 1, total
            assert total["failed_inputs"] == [os.path.join(inputs, CORRUPT)] and not total["interrupted"], total
            assert "[1/50]" not in r.stderr, "no progress lines with --json"
            assert "1 of 50 files failed" in r.stderr, r.stderr
        check("--json: one object per file per line (ok, output, summary or error) and a total line", json_lines)

        def unreachable():
            down = f"127.0.0.1:{free_port()}"
            r = smooth(os.path.join(inputs, "scan_01.ply"), os.path.join(inputs, "scan_02.ply"), "-o",
                       os.path.join(tmp, "down"), *FLOW, "--server", down, "--retries", "0", "--timeout", "20")
            assert r.returncode == 3, (r.returncode, r.stderr)
            assert "2 of 2 files failed" in r.stderr and "UNAVAILABLE" in r.stderr, r.stderr
        check("a server nobody answers on: every file fails, exit 3", unreachable)
    finally:
        one.stop()
        two.stop()

    def quiet():
        r = smooth(inputs, "-o", os.path.join(tmp, "quiet"), *FLOW, "--jobs", "2", "--quiet")
        assert r.returncode == 1, (r.returncode, r.stderr)
        assert r.stdout == "", r.stdout
        assert r.stderr.splitlines() == ["meshsmooth: 1 of 50 files failed:",
                                         r.stderr.splitlines()[1]], r.stderr
        assert CORRUPT in r.stderr
    check("--quiet: nothing but the failure report", quiet)

    def local_batch_equals_local_runs():
        one_file_runs(os.path.join(tmp, "local-single"))
        r = smooth(inputs, "-o", os.path.join(tmp, "local"), *FLOW, "--jobs", "2", "--json")
        assert r.returncode == 1, (r.returncode, r.stderr)
        same_outputs(os.path.join(tmp, "local"), os.path.join(tmp, "local-single"))
        ids = [json.loads(line)["summary"]["job_id"] for line in r.stdout.splitlines()[:-1]
               if json.loads(line)["ok"]]
        assert len(ids) == 49 and len(set(ids)) == 49, f"job ids repeat: {sorted(ids)[:4]}"
    check("without --server (jobs in this process), --jobs 2: the outputs are the one-file runs', "
          "each job its own id", local_batch_equals_local_runs)

    def lists_and_globs():
        listing = write_text(os.path.join(tmp, "list.txt"),
                             f"# two scans and a built-in shape\n{inputs}/scan_03.ply\n\n  {inputs}/scan_1[0-2].*  \n"
                             "builtin:noisy-plane\n")
        r = smooth("--batch", listing, "-o", os.path.join(tmp, "listed"), *FLOW, "--format", "obj", "-q")
        assert r.returncode == 0, (r.returncode, r.stderr)
        got = sorted(os.listdir(os.path.join(tmp, "listed")))
        assert got == ["noisy-plane.obj", "scan_03.obj", "scan_10.obj", "scan_11.obj", "scan_12.obj"], got
        # A quoted glob, and one input with -o ending in '/'; without the '/', a folder is no -o FILE.
        r = smooth(f"{inputs}/scan_2*.ply", "-o", os.path.join(tmp, "glob"), *FLOW, "-q")
        assert r.returncode == 0, (r.returncode, r.stderr)
        assert len(os.listdir(os.path.join(tmp, "glob"))) == 8, os.listdir(os.path.join(tmp, "glob"))
        r = smooth(os.path.join(inputs, "scan_01.ply"), "-o", os.path.join(tmp, "glob") + "/", *FLOW)
        assert r.returncode == 0 and "1 file: 1 smoothed, 0 failed" in r.stdout, (r.returncode, r.stdout, r.stderr)
        r = smooth(os.path.join(inputs, "scan_01.ply"), "-o", os.path.join(tmp, "glob"), *FLOW)
        assert r.returncode == 2 and "--output" in r.stderr, (r.returncode, r.stderr)
    check("--batch FILE (comments, blanks, globs, builtin:NAME) with --format obj; a quoted glob; -o FOLDER/",
          lists_and_globs)

    def help_documents_batches():
        r = run([cli, "smooth", "--help"])
        assert r.returncode == 0, r.returncode
        text = " ".join(r.stdout.split())
        for words in ("--batch", "--jobs", "--format", "ID-1, ID-2", "a failed file does not stop the others",
                      "exit 1 when any failed"):
            assert words in text, f"'{words}' missing from smooth --help"
        r = run([cli, "--help"])
        assert "(a batch: any file)" in " ".join(r.stdout.split()), r.stdout
    check("smooth --help documents --batch, --jobs, --format, the batch's job ids and exit status",
          help_documents_batches)

    def refusals_exit_2():
        other = os.path.join(tmp, "other")
        os.makedirs(other)
        write_ply(os.path.join(other, "scan_01.ply"), *noisy_grid(1))
        regular = write_text(os.path.join(tmp, "regular.txt"), "x")
        glb = write_text(os.path.join(tmp, "scene.glb"), "x")
        a, b = os.path.join(inputs, "scan_01.ply"), os.path.join(other, "scan_01.ply")
        cases = [
            ([a, b, "-o", os.path.join(tmp, "r1")], [a, b, "would both be written"]),
            ([a, os.path.join(inputs, "scan_02.ply"), "-o", regular], [regular, "not a folder"]),
            ([inputs, "-o", inputs, "--format", "ply"], ["written over the input"]),
            ([a, "-o", os.path.join(tmp, "one.obj"), "--format", "obj"], ["--format"]),
            ([a, glb, "-o", os.path.join(tmp, "r2")], [glb, "glTF"]),
            ([a, b, "-o", os.path.join(tmp, "r3"), "--jobs", "0"], ["--jobs"]),
            ([a, "builtin:sphere", "-o", os.path.join(tmp, "r4"), "--edgebreaker"], ["--edgebreaker", "--format drc"]),
            ([a, "builtin:sphere", "-o", os.path.join(tmp, "r5.ply")], ["folder"]),
            (["-o", os.path.join(tmp, "r6")], ["input"]),
            ([os.path.join(tmp, "none", "*.ply"), "-o", os.path.join(tmp, "r7")], ["matches no file"]),
        ]
        for args, words in cases:
            r = smooth(*args, *FLOW)
            assert r.returncode == 2, (args, r.returncode, r.stderr)
            for w in words:
                assert w in r.stderr, (args, w, r.stderr)
        for k in (1, 2, 3, 4, 6, 7):
            assert not os.path.exists(os.path.join(tmp, f"r{k}")), k
        assert not os.path.exists(os.path.join(tmp, "r5.ply"))
    check("two inputs with one output, -o a file, an output over an input, --format for one file, a glTF input, "
          "--jobs 0, --edgebreaker without .drc, -o FILE.ply for a batch, no input, an empty glob: exit 2, "
          "nothing written", refusals_exit_2)

    def ctrl_c_cancels():
        out = os.path.join(tmp, "interrupted")
        big = os.path.join(tmp, "big.ply")
        r = smooth("builtin:noisy-sphere-large", "-o", big, *FLOW, "-q")
        assert r.returncode == 0, r.stderr
        # Two long jobs in flight, a third waiting for them.
        p = subprocess.Popen([cli, "smooth", "builtin:noisy-sphere-large", big, "builtin:sphere", "-o", out, "--flow", "taubin", "--iterations", "10000", "--jobs", "2"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(1.5)
        p.send_signal(signal.SIGINT)
        t0 = time.time()
        stdout, err = p.communicate(timeout=20)
        assert p.returncode == 130, (p.returncode, err)
        assert time.time() - t0 < 5, time.time() - t0
        assert "interrupted" in err and "0 of 3 files written" in err, err
        assert os.listdir(out) == [], os.listdir(out)
        assert "files failed" not in err, err  # cancelled jobs are not failures
    check("Ctrl-C: the jobs in flight cancelled, none started after, exit 130, nothing written", ctrl_c_cancels)


if __name__ == "__main__":
    raise SystemExit(main())
