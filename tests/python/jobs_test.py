#!/usr/bin/python3
"""Jobs that outlive a connection (smoothing.proto: Submit .. FetchResult) against real meshsmoothd
processes with a job store, from a client written against the proto alone.

Run (ctest does this):
  /usr/bin/python3 tests/python/jobs_test.py --server build/server/meshsmoothd --proto-root proto \
      --cli build/client/meshsmooth

Checks: a submit sent three times (the first cut a third in) gives one job and one run; a
broken upload resumes from the bytes the server holds; 20 jobs on a one-worker server killed
with SIGKILL while the third runs all end SUCCEEDED after a restart, with the bytes Smooth gives;
a fetch resumes from an offset with the same SHA-256; a running job cancelled ends CANCELLED and
frees its worker; a deleted job's bytes leave the store; the watch's events and its resumption;
paging; and the bad inputs: a checksum mismatch (DATA_LOSS, never queued), unknown ids
(NOT_FOUND), a chunk at the wrong offset (the expected offset named), a full disk budget
(RESOURCE_EXHAUSTED before any byte is kept), a store another process holds; with --cli, the
CLI's submit, status, fetch, jobs and cancel.
Needs python3-grpcio, python3-numpy, protobuf-compiler-grpc and draco (draco_encoder).
"""

import hashlib
import os
import re
import time

import grpc
import numpy as np

from e2e_client_test import generate_stubs, icosphere, write_ascii_ply
from harness import Server, parser, require, run, run_checks

CHUNK = 16 * 1024  # small, so that the test meshes go in several chunks
DEADLINE_S = 30.0
# A job of a few tenths of a second on one worker (icosphere(4), 2,562 vertices).
SHORT_SPEC = {"flow": "laplacian", "iterations": 400}
# A job of about a third of a second (icosphere(4)), for the restart.
RESTART_SPEC = {"flow": "laplacian", "iterations": 8000}
# A job of many seconds, to be cancelled while it runs.
LONG_SPEC = {"flow": "laplacian", "iterations": 100000}


class Client:
    """The stubs and a channel to one server."""

    def __init__(self, pb2, pb2_grpc, address):
        self.pb2 = pb2
        opts = [("grpc.max_receive_message_length", -1), ("grpc.max_send_message_length", -1)]
        self.channel = grpc.insecure_channel(address, options=opts)
        self.stub = pb2_grpc.MeshSmootherStub(self.channel)

    def close(self):
        self.channel.close()

    def spec(self, fields):
        return self.pb2.JobSpec(**fields)

    def submit(self, request_id, spec, data, offset=0, cut_at=None, sha=None, chunk=CHUNK):
        """One Submit call: the start, then chunks from `offset`; with cut_at the stream breaks
        (the client cancels) once that many bytes were sent. Returns the SubmitResponse."""
        pb2 = self.pb2
        start = pb2.SubmitStart(request_id=request_id, spec=spec, total_bytes=len(data),
                                sha256=sha if sha is not None else hashlib.sha256(data).digest())

        def requests():
            yield pb2.SubmitRequest(start=start)
            off = offset
            while off < len(data):
                if cut_at is not None and off >= cut_at:
                    time.sleep(0.3)  # the chunks sent reach the server before the cut
                    raise ConnectionAbortedError("the test cuts the upload")
                piece = data[off:off + chunk]
                yield pb2.SubmitRequest(chunk=pb2.UploadChunk(offset=off, data=piece))
                off += len(piece)

        return self.stub.Submit(requests(), timeout=DEADLINE_S)

    def get(self, job_id):
        return self.stub.GetJob(self.pb2.GetJobRequest(job_id=job_id), timeout=DEADLINE_S)

    def wait_state(self, job_id, states, seconds=60.0):
        """The job once its state is one of `states` (names), polled every 20 ms."""
        wanted = {self.pb2.JobState.Value(s) for s in states}
        t_end = time.time() + seconds
        while True:
            job = self.get(job_id)
            if job.state in wanted:
                return job
            require(time.time() < t_end,
                    f"job {job_id} still {self.pb2.JobState.Name(job.state)} after {seconds} s, not {states}")
            time.sleep(0.02)

    def fetch(self, job_id, offset=0):
        """(bytes from offset, messages) of FetchResult."""
        msgs = list(self.stub.FetchResult(self.pb2.FetchResultRequest(job_id=job_id, offset=offset),
                                          timeout=DEADLINE_S))
        return b"".join(m.data for m in msgs), msgs

    def smooth(self, spec, data):
        """The result bytes of the one-call Smooth."""
        pb2 = self.pb2

        def requests():
            yield pb2.SmoothRequest(spec=spec)
            for off in range(0, len(data), CHUNK):
                yield pb2.SmoothRequest(mesh_chunk=data[off:off + CHUNK])

        out = b""
        for r in self.stub.Smooth(requests(), timeout=DEADLINE_S):
            if r.WhichOneof("kind") == "result_chunk":
                out += r.result_chunk
        return out


def code_of(fn):
    """(status code, details) of a call that must fail."""
    try:
        fn()
    except grpc.RpcError as e:
        return e.code(), e.details()
    raise AssertionError("the call succeeded")


def make_meshes(tmp, count, subdivisions=4):
    """`count` noisy icospheres (each its own seed) as lossless Draco bytes."""
    verts, faces = icosphere(subdivisions)
    out = []
    for seed in range(count):
        v = (verts + np.random.default_rng(seed).uniform(-0.01, 0.01, size=verts.shape)).astype(np.float32)
        ply, drc = os.path.join(tmp, f"m{seed}.ply"), os.path.join(tmp, f"m{seed}.drc")
        write_ascii_ply(ply, v, faces)
        r = run(["draco_encoder", "-i", ply, "-o", drc, "-qp", "0", "-cl", "0"])
        require(r.returncode == 0, f"draco_encoder failed: {r.stdout} {r.stderr}")
        with open(drc, "rb") as f:
            out.append(f.read())
    return out


def store_bytes(store):
    """Bytes of the store's files on disk."""
    return sum(os.path.getsize(os.path.join(store, f)) for f in os.listdir(store))


def runs_of(server, job_id):
    """Runs of job_id the server logged (one line per run)."""
    return [s for j, s in server.job_lines() if j == job_id]


# ----------------------------------------------------------------------------------------------
# Checks


def check_idempotent_submit(c, server, data):
    spec = c.spec(SHORT_SPEC)
    try:
        c.submit("idem-1", spec, data, cut_at=len(data) // 3)
        raise AssertionError("the cut submit succeeded")
    except grpc.RpcError as e:
        # grpcio reports the client's own cut as UNKNOWN ("Exception iterating requests!").
        require(e.code() in (grpc.StatusCode.CANCELLED, grpc.StatusCode.UNKNOWN),
                f"the cut submit ended {e.code()}: {e.details()}")
    held = c.stub.QueryUpload(c.pb2.QueryUploadRequest(request_id="idem-1"), timeout=DEADLINE_S)
    require(0 < held.bytes_received < len(data) and not held.committed,
            f"after the cut the server holds {held.bytes_received} of {len(data)} bytes")
    second = c.submit("idem-1", spec, data, offset=held.bytes_received)
    require(second.committed and len(second.job.job_id) == 32, f"resumed submit: {second}")
    third = c.submit("idem-1", spec, data)
    fourth = c.submit("idem-1", spec, data)
    ids = {second.job.job_id, third.job.job_id, fourth.job.job_id}
    require(len(ids) == 1, f"three submits gave jobs {ids}")
    job = c.wait_state(second.job.job_id, ["JOB_STATE_SUCCEEDED"])
    require(job.attempts == 1, f"attempts {job.attempts}")
    listed = c.stub.ListJobs(c.pb2.ListJobsRequest(), timeout=DEADLINE_S).jobs
    require([j.job_id for j in listed if j.request_id == "idem-1"] == [job.job_id], f"listed: {listed}")
    time.sleep(0.2)
    require(runs_of(server, job.job_id) == ["OK"], f"runs logged: {runs_of(server, job.job_id)}")
    require(job.upload_sha256 == hashlib.sha256(data).digest() and job.upload_bytes == len(data),
            f"upload: {job.upload_bytes} bytes held once of {len(data)}, SHA-256 equal")
    # The same request id with other bytes is another job: refused.
    code, details = code_of(lambda: c.submit("idem-1", spec, data[:-1] + b"\0"))
    require(code == grpc.StatusCode.ALREADY_EXISTS and "idem-1" in details, (code, details))
    return job


def check_result_is_smooths(c, job, spec, data):
    got, msgs = c.fetch(job.job_id)
    want = c.smooth(spec, data)
    require(got == want, f"fetched {len(got)} bytes, Smooth gives {len(want)}; equal: {got == want}")
    require(all(m.total_bytes == len(got) and m.sha256 == hashlib.sha256(got).digest() for m in msgs),
            "every message carries the result's length and SHA-256")
    require(job.result_sha256 == hashlib.sha256(got).digest() and job.result_bytes == len(got), "Job's checksum")
    return got


def check_fetch_resumes(c, job, whole):
    half = len(whole) // 2
    tail, msgs = c.fetch(job.job_id, offset=half)
    require(tail == whole[half:], "the bytes from the half are the tail")
    require(msgs[0].offset == half, f"first message's offset {msgs[0].offset}")
    require(hashlib.sha256(whole[:half] + tail).digest() == msgs[0].sha256, "the joined bytes match the SHA-256")
    end, _ = c.fetch(job.job_id, offset=len(whole))
    require(end == b"", "nothing from the end")
    code, details = code_of(lambda: c.fetch(job.job_id, offset=len(whole) + 1))
    require(code == grpc.StatusCode.OUT_OF_RANGE, (code, details))


def check_watch(c, data):
    pb2 = c.pb2
    sub = c.submit("watch-1", c.spec(SHORT_SPEC), data)
    events = list(c.stub.WatchJob(pb2.WatchJobRequest(job_id=sub.job.job_id), timeout=DEADLINE_S))
    seqs = [e.sequence for e in events]
    require(seqs == sorted(set(seqs)), f"sequences rise: {seqs}")
    require(events[-1].job.state == pb2.JOB_STATE_SUCCEEDED, f"last event {events[-1].job.state}")
    require(all(e.sequence == e.job.event_sequence for e in events), "sequence = job.event_sequence")
    again = list(c.stub.WatchJob(pb2.WatchJobRequest(job_id=sub.job.job_id, after_sequence=seqs[-1]),
                                 timeout=DEADLINE_S))
    require(again == [], f"a watch resumed after the last event gets nothing more: {again}")
    older = list(c.stub.WatchJob(pb2.WatchJobRequest(job_id=sub.job.job_id, after_sequence=seqs[-1] - 1),
                                 timeout=DEADLINE_S))
    require(len(older) == 1 and older[0].sequence == seqs[-1], f"resumed one before the last: {older}")


def check_cancel_running(c, server, data, small):
    pb2 = c.pb2
    sub = c.submit("cancel-1", c.spec(LONG_SPEC), data)
    job_id = sub.job.job_id
    c.wait_state(job_id, ["JOB_STATE_RUNNING"])
    time.sleep(0.3)
    t0 = time.time()
    job = c.stub.CancelJob(pb2.CancelJobRequest(job_id=job_id), timeout=DEADLINE_S)
    require(job.state == pb2.JOB_STATE_CANCELLED and job.HasField("end_time"), f"cancel answered {job}")
    # The run stops: its log line comes within a second (an iteration takes milliseconds).
    while not runs_of(server, job_id):
        require(time.time() - t0 < 1.0, "no log line of the cancelled run within 1 s")
        time.sleep(0.01)
    again = c.stub.CancelJob(pb2.CancelJobRequest(job_id=job_id), timeout=DEADLINE_S)
    require(again.state == pb2.JOB_STATE_CANCELLED, "a second cancel: still CANCELLED")
    require(c.get(job_id).state == pb2.JOB_STATE_CANCELLED, "stays CANCELLED")
    code, _ = code_of(lambda: c.fetch(job_id))
    require(code == grpc.StatusCode.FAILED_PRECONDITION, f"fetch of a cancelled job: {code}")
    # A job queued behind a running one, cancelled, never runs; the worker is free again after.
    blocker = c.submit("cancel-blocker", c.spec(LONG_SPEC), data).job.job_id
    c.wait_state(blocker, ["JOB_STATE_RUNNING"])
    queued = c.submit("cancel-queued", c.spec(SHORT_SPEC), small).job.job_id
    require(c.get(queued).state == pb2.JOB_STATE_QUEUED, "queued behind the running job")
    require(c.stub.CancelJob(pb2.CancelJobRequest(job_id=queued), timeout=DEADLINE_S).state ==
            pb2.JOB_STATE_CANCELLED, "the queued job cancelled")
    c.stub.CancelJob(pb2.CancelJobRequest(job_id=blocker), timeout=DEADLINE_S)
    nxt = c.submit("cancel-after", c.spec(SHORT_SPEC), small)
    c.wait_state(nxt.job.job_id, ["JOB_STATE_SUCCEEDED"], seconds=20)
    queued_job = c.get(queued)
    require(queued_job.attempts == 0 and not runs_of(server, queued), "the cancelled queued job never ran")
    return job_id


def check_delete(c, store, job_id, running_id):
    pb2 = c.pb2
    code, details = code_of(lambda: c.stub.DeleteJob(pb2.DeleteJobRequest(job_id=running_id), timeout=DEADLINE_S))
    require(code == grpc.StatusCode.FAILED_PRECONDITION and "cancel" in details, (code, details))
    before = store_bytes(store)
    c.stub.DeleteJob(pb2.DeleteJobRequest(job_id=job_id), timeout=DEADLINE_S)
    after = store_bytes(store)
    require(after < before, f"store {before} -> {after} bytes after the delete")
    code, _ = code_of(lambda: c.get(job_id))
    require(code == grpc.StatusCode.NOT_FOUND, f"a deleted job: {code}")
    return before - after


def check_bad_input(c, data):
    pb2 = c.pb2
    before = len(c.stub.ListJobs(pb2.ListJobsRequest(), timeout=DEADLINE_S).jobs)
    wrong = hashlib.sha256(data + b"x").digest()
    code, details = code_of(lambda: c.submit("bad-sum", c.spec(SHORT_SPEC), data, sha=wrong))
    require(code == grpc.StatusCode.DATA_LOSS and "SHA-256" in details, (code, details))
    require(len(c.stub.ListJobs(pb2.ListJobsRequest(), timeout=DEADLINE_S).jobs) == before, "a job was queued")
    held = c.stub.QueryUpload(pb2.QueryUploadRequest(request_id="bad-sum"), timeout=DEADLINE_S)
    require(held.bytes_received == 0 and not held.committed, f"the bytes were kept: {held}")
    # A chunk at the wrong offset names the expected one.
    try:
        c.submit("bad-offset", c.spec(SHORT_SPEC), data, cut_at=2 * CHUNK)
    except grpc.RpcError:
        pass
    code, details = code_of(lambda: c.submit("bad-offset", c.spec(SHORT_SPEC), data, offset=CHUNK))
    require(code == grpc.StatusCode.FAILED_PRECONDITION and f"send from offset {2 * CHUNK}" in details,
            (code, details))
    unknown = "0" * 32
    for name, call in [("GetJob", lambda: c.get(unknown)),
                       ("CancelJob", lambda: c.stub.CancelJob(pb2.CancelJobRequest(job_id=unknown), timeout=5)),
                       ("DeleteJob", lambda: c.stub.DeleteJob(pb2.DeleteJobRequest(job_id=unknown), timeout=5)),
                       ("FetchResult", lambda: c.fetch(unknown)),
                       ("WatchJob", lambda: list(c.stub.WatchJob(pb2.WatchJobRequest(job_id=unknown), timeout=5)))]:
        code, details = code_of(call)
        require(code == grpc.StatusCode.NOT_FOUND and unknown in details, (name, code, details))
    code, details = code_of(lambda: c.submit("bad-spec", c.spec({"flow": "nope"}), data))
    require(code == grpc.StatusCode.INVALID_ARGUMENT, (code, details))
    code, details = code_of(lambda: c.submit("", c.spec(SHORT_SPEC), data))
    require(code == grpc.StatusCode.INVALID_ARGUMENT and "request_id" in details, (code, details))


def check_paging(c):
    pb2 = c.pb2
    seen, token, pages = [], "", 0
    while True:
        r = c.stub.ListJobs(pb2.ListJobsRequest(page_size=7, page_token=token), timeout=DEADLINE_S)
        seen += [j.job_id for j in r.jobs]
        pages += 1
        token = r.next_page_token
        if not token:
            break
    require(len(seen) == len(set(seen)) == 20 and pages == 3, f"{len(seen)} jobs in {pages} pages")
    done = c.stub.ListJobs(pb2.ListJobsRequest(states=[pb2.JOB_STATE_SUCCEEDED]), timeout=DEADLINE_S).jobs
    require(len(done) == 20, f"{len(done)} SUCCEEDED")
    none = c.stub.ListJobs(pb2.ListJobsRequest(states=[pb2.JOB_STATE_RUNNING]), timeout=DEADLINE_S).jobs
    require(len(none) == 0, "none RUNNING")


def check_restart(a, pb2, pb2_grpc, tmp, meshes):
    """20 jobs to a one-worker server; SIGKILL while the third runs; a restart runs them all."""
    store = os.path.join(tmp, "restart-store")
    log1 = os.path.join(tmp, "restart-1.log")
    s = Server(a.server, "--workers", "1", "--job-store", store, stderr=log1)
    c = Client(pb2, pb2_grpc, s.address)
    spec = c.spec(RESTART_SPEC)
    ids = [c.submit(f"restart-{i}", spec, m).job.job_id for i, m in enumerate(meshes)]
    c.wait_state(ids[2], ["JOB_STATE_RUNNING"])
    s.proc.kill()
    s.stop()
    c.close()
    require(s.proc.returncode == -9, f"exit {s.proc.returncode}")
    s2 = Server(a.server, "--workers", "1", "--job-store", store, stderr=os.path.join(tmp, "restart-2.log"))
    try:
        c = Client(pb2, pb2_grpc, s2.address)
        jobs = [c.wait_state(i, ["JOB_STATE_SUCCEEDED", "JOB_STATE_FAILED"], seconds=120) for i in ids]
        states = [pb2.JobState.Name(j.state) for j in jobs]
        require(all(st == "JOB_STATE_SUCCEEDED" for st in states), f"states {states}")
        require(jobs[2].attempts == 2, f"the killed job's attempts {jobs[2].attempts}")
        require(all(j.attempts == 1 for j in jobs[3:]), "the queued jobs ran once")
        for job, mesh in zip(jobs, meshes):
            got, _ = c.fetch(job.job_id)
            require(got == c.smooth(spec, mesh), f"job {job.job_id}: not Smooth's bytes")
        check_paging(c)
        c.close()
    finally:
        s2.stop()
    return s


def check_store_in_use(a, store):
    r = run([a.server, "--listen", "127.0.0.1:0", "--job-store", store], timeout=10)
    require(r.returncode == 1 and "in use by another meshsmoothd" in r.stderr, (r.returncode, r.stderr))


def check_budget(a, pb2, pb2_grpc, tmp, data):
    store = os.path.join(tmp, "small-store")
    with Server(a.server, "--job-store", store, "--job-store-max-bytes", str(len(data) - 1)) as s:
        c = Client(pb2, pb2_grpc, s.address)
        code, details = code_of(lambda: c.submit("too-big", c.spec(SHORT_SPEC), data))
        require(code == grpc.StatusCode.RESOURCE_EXHAUSTED and "no room" in details, (code, details))
        held = c.stub.QueryUpload(pb2.QueryUploadRequest(request_id="too-big"), timeout=DEADLINE_S)
        require(held.bytes_received == 0, "bytes kept")
        c.close()


def check_no_store(a, pb2, pb2_grpc):
    with Server(a.server) as s:
        c = Client(pb2, pb2_grpc, s.address)
        code, details = code_of(lambda: c.get("x"))
        require(code == grpc.StatusCode.UNIMPLEMENTED and "--job-store" in details, (code, details))
        c.close()


def check_cli(a, c, server, tmp):
    """The CLI's job commands against the same server."""
    cli = [a.cli]
    where = ["--server", server.address]
    out = os.path.join(tmp, "cli.drc")
    r = run(cli + ["submit", "builtin:noisy-sphere", "--flow", "laplacian", "--iterations", "50", "--wait", "-o", out]
            + where, timeout=60)
    require(r.returncode == 0 and re.fullmatch(r"[0-9a-f]{32}\n", r.stdout), (r.returncode, r.stdout, r.stderr))
    job_id = r.stdout.strip()
    require("succeeded" in r.stderr, f"the watch's lines: {r.stderr!r}")
    again = run(cli + ["submit", "builtin:noisy-sphere", "--flow", "laplacian", "--iterations", "50"] + where)
    require(again.returncode == 0 and again.stdout.strip() == job_id, f"the same input again: {again.stdout!r}")
    status = run(cli + ["status", job_id] + where)
    require(status.returncode == 0 and "succeeded" in status.stdout and "attempts 1" in status.stdout, status.stdout)
    fetched = os.path.join(tmp, "cli-fetch.drc")
    f = run(cli + ["fetch", job_id, "-o", fetched] + where)
    require(f.returncode == 0, f.stderr)
    with open(out, "rb") as x, open(fetched, "rb") as y:
        got = y.read()
        require(x.read() == got and hashlib.sha256(got).digest() == c.get(job_id).result_sha256, "fetch: same bytes")
    listed = run(cli + ["jobs", "--state", "succeeded"] + where)
    require(listed.returncode == 0 and job_id in listed.stdout, listed.stdout)
    cancel = run(cli + ["cancel", job_id] + where)
    require(cancel.returncode == 0 and cancel.stdout.strip() == "succeeded", f"cancel of an ended job: {cancel.stdout}")
    missing = run(cli + ["status", "0" * 32] + where)
    require(missing.returncode == 1 and "no job" in missing.stderr, (missing.returncode, missing.stderr))
    bad = run(cli + ["fetch", job_id, "-o", os.path.join(tmp, "x.ply")] + where)
    require(bad.returncode == 2 and ".drc" in bad.stderr, (bad.returncode, bad.stderr))
    helps = run(cli + ["--help"]).stdout
    require(all(w in helps for w in ("submit", "status", "watch", "fetch", "cancel", "jobs")), helps)


def main():
    ap = parser(__doc__, required=("server", "proto-root"), optional=("cli",))
    a = ap.parse_args()

    def body(checks, tmp):
        pb2, pb2_grpc = checks.check("python stubs generated from the proto", generate_stubs, a.proto_root, tmp)
        meshes = checks.check("20 noisy icospheres as Draco", make_meshes, tmp, 20)
        big = checks.check("a larger icosphere as Draco", make_meshes, tmp, 1, 5)
        store = os.path.join(tmp, "store")
        with Server(a.server, "--workers", "1", "--max-iterations", "1000000", "--job-store", store,
                    stderr=Server.KEEP) as s:
            c = Client(pb2, pb2_grpc, s.address)
            job = checks.check("the same submit three times (the first cut a third in): one job, one run",
                               check_idempotent_submit, c, s, meshes[0])
            whole = checks.check("a job's result is Smooth's bytes, with its SHA-256",
                                 check_result_is_smooths, c, job, c.spec(SHORT_SPEC), meshes[0])
            checks.check("a fetch resumes from half the result", check_fetch_resumes, c, job, whole)
            checks.check("a watch sees the job to SUCCEEDED and resumes after its last event",
                         check_watch, c, meshes[1])
            cancelled = checks.check("a running job cancelled ends CANCELLED within a second and frees its worker",
                                     check_cancel_running, c, s, big[0], meshes[2])
            # A job to delete with its result, and one that has not ended.
            keep = c.submit("delete-1", c.spec(SHORT_SPEC), big[0]).job.job_id
            c.wait_state(keep, ["JOB_STATE_SUCCEEDED"])
            running = c.submit("delete-2", c.spec(LONG_SPEC), meshes[3]).job.job_id
            freed = checks.check("a deleted job's bytes leave the store (running: refused)",
                                 check_delete, c, store, keep, running)
            print(f"delete freed {freed} bytes", flush=True)
            c.stub.CancelJob(pb2.CancelJobRequest(job_id=running), timeout=DEADLINE_S)
            checks.check("bad input: checksum, offset, unknown ids, spec, request id", check_bad_input, c, meshes[4])
            checks.check("a second meshsmoothd on the same store is refused", check_store_in_use, a, store)
            if a.cli:
                checks.check("the CLI: submit --wait, the same submit again, status, fetch, jobs, cancel",
                             check_cli, a, c, s, tmp)
            c.close()
            del cancelled
        checks.check("restart: 20 jobs, SIGKILL during the third, all SUCCEEDED with Smooth's bytes",
                     check_restart, a, pb2, pb2_grpc, tmp, meshes)
        checks.check("a full disk budget: RESOURCE_EXHAUSTED before any byte is kept",
                     check_budget, a, pb2, pb2_grpc, tmp, meshes[0])
        checks.check("without --job-store the job methods are UNIMPLEMENTED", check_no_store, a, pb2, pb2_grpc)

    return run_checks(body, tmp_prefix="meshsmooth-jobs-")


if __name__ == "__main__":
    raise SystemExit(main())
