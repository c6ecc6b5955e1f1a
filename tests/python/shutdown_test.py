#!/usr/bin/python3
"""meshsmoothd's shutdown ends with the work: SIGTERM while one job runs, with --grace-seconds 10,
and the job ends OK with its whole result, then the process exits with status 0 within 0.5 s
of the job's last message, in every one of --trials trials; a health watch and a reflection
stream held open by the client do not hold it. Then the other side: a job still running at the end of a 1 s grace is
cut with UNAVAILABLE and the exit status is 1.

Run by ctest: shutdown_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd
    --proto-root proto [--trials 20]
The job is sized to ~1.5 s on this machine (one job timed first); its mesh, a noisy grid of
262,144 vertices, gives a result of several megabytes, whose write outruns the socket: the case
where gRPC's library teardown used to keep the process for up to 10 s more. Python's own gRPC
client (stubs generated from proto/ at test time) times the job's end. Prints one line per check and
ends with 'N passed, M failed'.
"""
import os
import signal
import sys
import threading
import time

import grpc
import numpy as np

from e2e_client_test import generate_stubs
from harness import Server, parser, require, run, run_checks

EXIT_AFTER_JOB_S = 0.5
JOB_SECONDS = 1.5
GRID = 512  # vertices a side


def write_noisy_grid(path, n=GRID, seed=1):
    """A binary PLY of an n x n grid on the unit square, two triangles a cell, z noise of 0.3 x
    the spacing."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    verts = np.stack([u.ravel(), v.ravel(), rng.uniform(-0.3, 0.3, n * n) / (n - 1)], axis=1).astype("<f4")
    i = (np.arange(n - 1)[None, :] + n * np.arange(n - 1)[:, None]).ravel()
    tris = np.concatenate([np.stack([i, i + 1, i + n + 1], 1), np.stack([i, i + n + 1, i + n], 1)])
    faces = np.zeros(len(tris), dtype=[("k", "u1"), ("v", "<i4", 3)])
    faces["k"], faces["v"] = 3, tris
    with open(path, "wb") as f:
        f.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\nproperty float x\n"
                 f"property float y\nproperty float z\nelement face {len(tris)}\n"
                 "property list uchar int vertex_indices\nend_header\n").encode())
        f.write(verts.tobytes())
        f.write(faces.tobytes())


class Job(threading.Thread):
    """One Smooth call on its own thread: `accepted` is set once the server took the job (a
    worker runs it); afterwards code, summary, result and end (the monotonic time the call's
    status arrived) hold what came back."""

    def __init__(self, pb2, stub, draco, iterations):
        super().__init__(daemon=True)
        self.pb2, self.stub, self.draco, self.iterations = pb2, stub, draco, iterations
        self.accepted = threading.Event()
        self.code, self.details, self.summary, self.result, self.end = None, "", None, b"", None

    def requests(self):
        spec = self.pb2.JobSpec(flow="taubin", iterations=self.iterations)
        yield self.pb2.SmoothRequest(spec=spec)
        for i in range(0, len(self.draco), 1 << 20):
            yield self.pb2.SmoothRequest(mesh_chunk=self.draco[i:i + (1 << 20)])

    def run(self):
        call = self.stub.Smooth(self.requests(), timeout=120)
        try:
            for r in call:
                kind = r.WhichOneof("kind")
                if kind == "accepted":
                    self.accepted.set()
                elif kind == "result_chunk":
                    self.result += r.result_chunk
                elif kind == "summary":
                    self.summary = r.summary
        except grpc.RpcError:
            pass
        self.end = time.monotonic()
        self.code, self.details = call.code(), call.details()
        self.accepted.set()  # also when it failed before


def watch_health(channel):
    """Holds a grpc.health.v1 Watch stream open on a thread, as a load balancer does."""
    watch = channel.unary_stream("/grpc.health.v1.Health/Watch", request_serializer=lambda b: b,
                                 response_deserializer=lambda b: b)

    def loop():
        try:
            for _ in watch(b"", timeout=120):
                pass
        except grpc.RpcError:
            pass
    threading.Thread(target=loop, daemon=True).start()


def open_reflection(channel, replies):
    """Holds a grpc.reflection.v1alpha stream open on a thread, as grpcurl or a debugger does:
    one list_services request (field 7, empty), then nothing until the server ends the call.
    Each reply goes to `replies`."""
    stream = channel.stream_stream("/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
                                   request_serializer=lambda b: b, response_deserializer=lambda b: b)
    never = threading.Event()

    def requests():
        yield b"\x3a\x00"
        never.wait()

    def loop():
        try:
            for reply in stream(requests(), timeout=120):
                replies.append(reply)
        except grpc.RpcError:
            pass
    threading.Thread(target=loop, daemon=True).start()


def main():
    ap = parser(__doc__, required=("cli", "server", "proto-root"))
    ap.add_argument("--trials", type=int, default=20)
    a = ap.parse_args()
    return run_checks(lambda checks, tmp: shutdown_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-shutdown-")


def shutdown_checks(a, check, tmp):
    pb2, pb2_grpc = generate_stubs(a.proto_root, tmp)
    ply, drc = os.path.join(tmp, "grid.ply"), os.path.join(tmp, "grid.drc")
    write_noisy_grid(ply)
    r = run([a.cli, "smooth", ply, "-o", drc, "--iterations", "1", "--quiet"])
    require(r.returncode == 0, f"making the input failed: {r.stderr}")
    with open(drc, "rb") as f:
        draco = f.read()

    def start(*flags):
        server = Server(a.server, "--workers", "1", "--threads-per-job", "1", *flags, stderr=Server.KEEP)
        channel = grpc.insecure_channel(server.address)
        return server, channel, pb2_grpc.MeshSmootherStub(channel)

    def calibrate():
        server, channel, stub = start()
        try:
            job = Job(pb2, stub, draco, 200)
            t = time.monotonic()
            job.start()
            job.join(120)
            require(job.code == grpc.StatusCode.OK, f"calibration job: {job.code} {job.details}")
            return max(20, min(10000, int(200 * JOB_SECONDS / (job.end - t))))
        finally:
            channel.close()
            server.stop()
    iterations = check("one job timed to size the trials' job", calibrate)
    if iterations is None:
        return

    def trial():
        server, channel, stub = start("--grace-seconds", "10")
        try:
            watch_health(channel)
            replies = []
            open_reflection(channel, replies)
            job = Job(pb2, stub, draco, iterations)
            job.start()
            require(job.accepted.wait(60) and job.code is None, f"the job did not start: {job.code} {job.details}")
            time.sleep(0.3)
            require(replies and b"meshsmooth.v1.MeshSmoother" in replies[0], f"reflection answered {replies}")
            t_signal = time.monotonic()
            server.proc.send_signal(signal.SIGTERM)
            job.join(60)
            rc = server.proc.wait(timeout=15)
            t_exit = time.monotonic()
        finally:
            channel.close()
            server.stop()
        require(job.code == grpc.StatusCode.OK, f"the job ended with {job.code}: {job.details}")
        require(job.summary is not None and job.summary.result_bytes == len(job.result),
                "the job's result is incomplete")
        require(len(job.result) > 4 << 20, f"a result of {len(job.result)} bytes: too small to fill the socket")
        require(job.end - t_signal >= 0.2, f"the job ended {job.end - t_signal:.2f} s after SIGTERM: it must run "
                                           "across the signal")
        return rc, job.end - t_signal, t_exit - job.end

    def all_trials():
        rows = []
        for i in range(a.trials):
            rows.append(trial())
            rc, job_after_signal, exit_after_job = rows[-1]
            print(f"  trial {i + 1}: job ended {job_after_signal:.2f} s after SIGTERM, exit {rc} "
                  f"{exit_after_job * 1000:.0f} ms after the job", flush=True)
        late = [(i + 1, rc, round(e, 2)) for i, (rc, _, e) in enumerate(rows) if rc != 0 or e > EXIT_AFTER_JOB_S]
        worst = max(e for _, _, e in rows)
        print(f"  {a.trials - len(late)} of {a.trials} trials exited 0 within {EXIT_AFTER_JOB_S} s of the job's end "
              f"(slowest {worst * 1000:.0f} ms)", flush=True)
        assert not late, f"trials (number, exit status, seconds after the job) that failed: {late}"
    check(f"SIGTERM during a ~{JOB_SECONDS} s job, --grace-seconds 10, a health watch and a reflection stream "
          f"open: the job ends OK and the "
          f"process exits 0 within {EXIT_AFTER_JOB_S} s of it, in {a.trials} of {a.trials} trials", all_trials)

    def grace_cuts():
        server, channel, stub = start("--grace-seconds", "1")
        try:
            job = Job(pb2, stub, draco, 10000)  # far longer than the grace
            job.start()
            require(job.accepted.wait(60) and job.code is None, f"the job did not start: {job.code} {job.details}")
            t_signal = time.monotonic()
            server.proc.send_signal(signal.SIGTERM)
            job.join(60)
            rc = server.proc.wait(timeout=15)
            exit_seconds = time.monotonic() - t_signal
        finally:
            channel.close()
            server.stop()
        assert job.code == grpc.StatusCode.UNAVAILABLE and "grace" in job.details, (job.code, job.details)
        assert rc == 1, f"exit status {rc}, not 1, after the grace cut a job"
        assert 1.0 <= exit_seconds <= 2.0, exit_seconds
        assert any("stopped; the grace cut 1 running job(s)" in line for line in server.stderr_lines()), \
            server.stderr_lines()
    check("a job still running at the end of a 1 s grace is cut with UNAVAILABLE and the exit status is 1",
          grace_cuts)


if __name__ == "__main__":
    sys.exit(main())
