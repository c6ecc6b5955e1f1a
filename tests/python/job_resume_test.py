#!/usr/bin/python3
"""Kept jobs over a connection that breaks: the CLI's submit and fetch through a TCP proxy that
cuts the connection part way, and a running job's cancel timed against its own iterations.

Run (ctest does this):
  /usr/bin/python3 tests/python/job_resume_test.py --server build/server/meshsmoothd \\
      --cli build/client/meshsmooth --proto-root proto

Checks: a 100 MB upload (a height field encoded losslessly) cut a third in resumes with
`meshsmooth submit --retries`, and the server keeps each byte once (the upload's SHA-256 equal,
meshsmooth_job_upload_bytes_total grown by at most 1.05x the upload); the same submit sent three
times, the first cut a third in, is one job and one run; `meshsmooth fetch --retries` cut at half
the result resumes to the bytes of an uninterrupted fetch; a running job cancelled stops within
one iteration's time (its progress: elapsed seconds over iterations) plus 0.2 s for the log line
to reach the test.
Needs python3-grpcio, python3-numpy, protobuf-compiler-grpc and draco (draco_encoder).
"""

import hashlib
import os
import re
import socket
import threading
import time
import urllib.request

import numpy as np

from e2e_client_test import generate_stubs
from harness import Server, metric_sum, parse_metrics, parser, require, run, run_checks
from jobs_test import DEADLINE_S, Client, runs_of

# A 1,667 x 1,667 height field, 36 bytes a vertex in Draco's lossless sequential encoding: 100 MB.
BIG_SIDE = 1667
# 500 x 500 (250,000 vertices, 7.4 MB): the job fetched and the job cancelled.
MID_SIDE = 500
# One implicit step a solve: ~75 ms an iteration on the 500 x 500 field in the dev build.
CANCEL_SPEC = {"flow": "laplacian", "iterations": 100000, "integration": 1, "step": 1.0}
# The time the cancelled run's log line may take beyond one iteration to reach the test, with
# the job sharing two cores with other tests under ctest -j2.
CANCEL_MARGIN_S = 0.2


class CuttingProxy:
    """A TCP proxy on 127.0.0.1:0 to a port: every connection passes both ways, byte for byte,
    except the first one to carry `cut_up` bytes towards the server (or `cut_down` towards the
    client), which is reset right there (SO_LINGER 0). Counts the bytes each way."""

    def __init__(self, target_port, cut_up=None, cut_down=None):
        self.target = target_port
        self.cut = {"up": cut_up, "down": cut_down}
        self.bytes = {"up": 0, "down": 0}
        self.cuts = 0
        self.lock = threading.Lock()
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.address = f"127.0.0.1:{self.listener.getsockname()[1]}"
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while True:
            try:
                client, _ = self.listener.accept()
            except OSError:
                return
            server = socket.create_connection(("127.0.0.1", self.target))
            conn = {"up": 0, "down": 0, "dead": False}
            for src, dst, way in ((client, server, "up"), (server, client, "down")):
                threading.Thread(target=self._pump, args=(src, dst, way, conn, (client, server)), daemon=True).start()

    def _pump(self, src, dst, way, conn, pair):
        while True:
            try:
                data = src.recv(1 << 16)
            except OSError:
                data = b""
            if not data:
                break
            with self.lock:
                limit = self.cut[way]
                if limit is not None and conn[way] + len(data) >= limit:
                    data = data[:limit - conn[way]]
                    self.cut[way] = None  # once
                    conn["dead"] = True
                conn[way] += len(data)
                self.bytes[way] += len(data)
            try:
                dst.sendall(data)
            except OSError:
                break
            if conn["dead"]:
                with self.lock:
                    self.cuts += 1
                for s in pair:
                    s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\1\0\0\0\0\0\0\0")
                    s.close()
                return
        for s in pair:
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass

    def close(self):
        self.listener.close()


def write_height_field(path, side, seed):
    """A side x side grid with uniform noise in z, as a binary PLY."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(side, dtype=np.float32), np.arange(side, dtype=np.float32))
    z = rng.uniform(-0.1, 0.1, size=(side, side)).astype(np.float32)
    v = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i = np.arange(side * side, dtype=np.int32).reshape(side, side)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel()
    faces = np.empty(2 * len(a), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"] = 3
    faces["i"] = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    with open(path, "wb") as out:
        out.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(v)}\nproperty float x\n"
                   f"property float y\nproperty float z\nelement face {len(faces)}\n"
                   "property list uchar int vertex_indices\nend_header\n").encode())
        out.write(v.astype("<f4").tobytes())
        out.write(faces.tobytes())


def make_drc(tmp, name, side, seed):
    """The height field as lossless sequential Draco (draco_encoder -qp 0 -cl 0): (path, bytes)."""
    ply, drc = os.path.join(tmp, f"{name}.ply"), os.path.join(tmp, f"{name}.drc")
    write_height_field(ply, side, seed)
    r = run(["draco_encoder", "-i", ply, "-o", drc, "-qp", "0", "-cl", "0"])
    require(r.returncode == 0, f"draco_encoder failed: {r.stdout} {r.stderr}")
    os.remove(ply)
    with open(drc, "rb") as f:
        return drc, f.read()


def job_upload_bytes(server):
    with urllib.request.urlopen(f"http://{server.metrics_address}/metrics", timeout=10) as r:
        return metric_sum(parse_metrics(r.read().decode()), "meshsmooth_job_upload_bytes_total")


def cli_submit(a, path, target, extra=()):
    r = run([a.cli, "submit", path, "--flow", "laplacian", "--iterations", "1", "--retries", "3", "--server", target,
             *extra], timeout=300)
    require(r.returncode == 0 and re.fullmatch(r"[0-9a-f]{32}\n", r.stdout), (r.returncode, r.stdout, r.stderr))
    return r.stdout.strip(), r.stderr


def check_big_upload(a, c, server, path, data):
    """100 MB cut a third in: resumed, each byte received once."""
    before = job_upload_bytes(server)
    proxy = CuttingProxy(server.port, cut_up=len(data) // 3)
    t0 = time.time()
    job_id, err = cli_submit(a, path, proxy.address)
    seconds = time.time() - t0
    proxy.close()
    received = job_upload_bytes(server) - before
    require(proxy.cuts == 1 and "resuming" in err, f"cuts {proxy.cuts}; the CLI said {err!r}")
    job = c.get(job_id)
    require(job.upload_bytes == len(data) and job.upload_sha256 == hashlib.sha256(data).digest(),
            f"held {job.upload_bytes} of {len(data)} bytes; SHA-256 equal: {job.upload_sha256 == hashlib.sha256(data).digest()}")
    ratio = received / len(data)
    require(1.0 <= ratio <= 1.05, f"the server received {received:.0f} bytes for an upload of {len(data)}: {ratio:.4f}x")
    print(f"100 MB upload: {len(data)} bytes, cut at {len(data) // 3}, received {received:.0f} "
          f"({ratio:.4f}x), {seconds:.1f} s through the proxy", flush=True)
    return job_id


def check_three_submits(a, c, server, path, data):
    """The same submit three times, the first cut a third in: one job, one run."""
    proxy = CuttingProxy(server.port, cut_up=len(data) // 3)
    first, err = cli_submit(a, path, proxy.address)
    proxy.close()
    require(proxy.cuts == 1 and "resuming" in err, f"cuts {proxy.cuts}; {err!r}")
    second, _ = cli_submit(a, path, server.address)
    third, _ = cli_submit(a, path, server.address)
    require(first == second == third, f"jobs {first} {second} {third}")
    job = c.wait_state(first, ["JOB_STATE_SUCCEEDED"])
    time.sleep(0.2)
    require(job.attempts == 1 and runs_of(server, first) == ["OK"], f"attempts {job.attempts}, runs {runs_of(server, first)}")
    return first


def check_fetch_cut(a, c, server, job_id, tmp):
    """meshsmooth fetch cut at half the result: resumed, the bytes of an uninterrupted fetch."""
    whole_path, cut_path = os.path.join(tmp, "whole.drc"), os.path.join(tmp, "cut.drc")
    r = run([a.cli, "fetch", job_id, "-o", whole_path, "--server", server.address])
    require(r.returncode == 0, r.stderr)
    with open(whole_path, "rb") as f:
        whole = f.read()
    proxy = CuttingProxy(server.port, cut_down=len(whole) // 2)
    r = run([a.cli, "fetch", job_id, "-o", cut_path, "--retries", "3", "--server", proxy.address])
    proxy.close()
    require(r.returncode == 0 and proxy.cuts == 1 and "resuming" in r.stderr, (r.returncode, proxy.cuts, r.stderr))
    with open(cut_path, "rb") as f:
        got = f.read()
    require(got == whole and hashlib.sha256(got).digest() == c.get(job_id).result_sha256,
            f"{len(got)} bytes after the cut, {len(whole)} uninterrupted; equal: {got == whole}")
    print(f"fetch: {len(whole)} bytes, cut at {len(whole) // 2}", flush=True)


def start_long_job(c, data):
    """A job of many slow iterations, once it smooths: it holds the one worker."""
    pb2 = c.pb2
    job_id = c.submit("cancel-timed", c.spec(CANCEL_SPEC), data, chunk=1 << 20).job.job_id
    t_end = time.time() + 120
    while True:
        job = c.get(job_id)
        if job.progress.phase == pb2.PROGRESS_PHASE_SMOOTHING and job.progress.iteration >= 2:
            return job_id
        require(time.time() < t_end, f"no 2 iterations within 120 s: {job.progress}")
        time.sleep(0.02)


def check_cancel_timed(c, server, job_id):
    """Cancelled while it runs: its run stops within one iteration's time + CANCEL_MARGIN_S, an
    iteration's time read from the job's progress over at least half a second and one iteration
    (under ASan beside other tests an iteration took 0.9 s)."""
    pb2 = c.pb2
    first = c.get(job_id).progress
    time.sleep(0.5)
    t_end = time.time() + 60
    while True:
        last = c.get(job_id).progress
        if last.iteration > first.iteration:
            break
        require(time.time() < t_end, f"no iteration in 60 s: {first} {last}")
        time.sleep(0.02)
    iteration_s = (last.elapsed_seconds - first.elapsed_seconds) / (last.iteration - first.iteration)
    t0 = time.time()
    done = c.stub.CancelJob(pb2.CancelJobRequest(job_id=job_id), timeout=DEADLINE_S)
    require(done.state == pb2.JOB_STATE_CANCELLED, f"cancel answered {pb2.JobState.Name(done.state)}")
    while not runs_of(server, job_id):
        require(time.time() - t0 < 10, "no log line of the cancelled run within 10 s")
        time.sleep(0.002)
    stopped_s = time.time() - t0
    require(runs_of(server, job_id) == ["CANCELLED"], runs_of(server, job_id))
    print(f"cancel: an iteration {iteration_s * 1000:.1f} ms (iterations {first.iteration}..{last.iteration} in "
          f"{last.elapsed_seconds - first.elapsed_seconds:.3f} s); the run stopped {stopped_s * 1000:.1f} ms after "
          "the cancel", flush=True)
    require(stopped_s <= iteration_s + CANCEL_MARGIN_S,
            f"stopped {stopped_s:.3f} s after the cancel; one iteration is {iteration_s:.3f} s (+{CANCEL_MARGIN_S} s)")


def main():
    ap = parser(__doc__, required=("server", "cli", "proto-root"))
    a = ap.parse_args()

    def body(checks, tmp):
        pb2, pb2_grpc = checks.check("python stubs generated from the proto", generate_stubs, a.proto_root, tmp)
        big_path, big = checks.check("a 100 MB upload: a height field as lossless Draco", make_drc, tmp, "big",
                                     BIG_SIDE, 1)
        mid_path, mid = checks.check("a 7 MB one", make_drc, tmp, "mid", MID_SIDE, 2)
        with Server(a.server, "--workers", "1", "--max-iterations", "1000000", "--job-store",
                    os.path.join(tmp, "store"), "--metrics-listen", "127.0.0.1:0", stderr=Server.KEEP) as s:
            c = Client(pb2, pb2_grpc, s.address)
            job_id = checks.check("the same submit three times (the first through a cut): one job, one run",
                                  check_three_submits, a, c, s, mid_path, mid)
            if job_id:
                checks.check("meshsmooth fetch cut at half the result resumes to the same bytes",
                             check_fetch_cut, a, c, s, job_id, tmp)
            # The long job holds the one worker while the 100 MB upload goes on: the upload's job,
            # which is not the point, waits QUEUED and is cancelled before it runs.
            long_id = checks.check("a job of slow iterations runs", start_long_job, c, mid)
            big_id = checks.check("100 MB cut a third in: resumed, each byte received once (<= 1.05x)",
                                  check_big_upload, a, c, s, big_path, big)
            if big_id:
                c.stub.CancelJob(pb2.CancelJobRequest(job_id=big_id), timeout=DEADLINE_S)
            if long_id:
                checks.check("a running job cancelled stops within one iteration's time (+0.2 s)",
                             check_cancel_timed, c, s, long_id)
            c.close()

    return run_checks(body, tmp_prefix="meshsmooth-resume-")


if __name__ == "__main__":
    raise SystemExit(main())
