#!/usr/bin/python3
"""The job store in PostgreSQL (--job-store postgresql://...): replicas of meshsmoothd sharing one
database, each taking the next job, one of them SIGKILLed mid-run and its job taken over when its
lease runs out. Starts a throwaway PostgreSQL of its own in a temporary directory (Debian's
postgresql-15 binaries; run as the postgres user when the test runs as root).

Run (ctest does this):
  /usr/bin/python3 tests/python/jobs_postgres_test.py --server build/server/meshsmoothd --proto-root proto

Checks: one replica end to end (a submit cut and resumed, the job to SUCCEEDED, its result
Smooth's bytes, a delete); then three replicas on the same database with --job-lease 3s and one
worker each: 60 small jobs submitted round-robin, one replica SIGKILLed while all three run a job,
watches on a third replica following jobs others run; all 60 end SUCCEEDED, each run counted once
per attempt (the attempts are the runs logged plus the runs killed), a lease takeover within the
lease + 2 s, each result fetched from a replica other than the one that ran it and byte-equal to
Smooth's, and the queue metrics (jobs by state, queue depth, oldest queued job, takeovers).
Skips (exit 77) without the PostgreSQL binaries; fails instead under CI=true.
Needs python3-grpcio, python3-numpy, protobuf-compiler-grpc, draco and postgresql-15.
"""

import hashlib
import os
import pwd
import shutil
import tempfile
import threading
import time
import urllib.request

import grpc

from e2e_client_test import generate_stubs
from harness import Server, free_port, metric_sum, parse_metrics, parser, require, run, run_checks
from jobs_test import DEADLINE_S, Client, code_of, make_meshes

PG_BIN = "/usr/lib/postgresql/15/bin"
LEASE_S = 3.0
JOBS = 60
REPLICAS = 3
# A job of about a quarter of a second on one worker (icosphere(3), 642 vertices; slower under ASan):
# long enough that the three replicas are busy once the 60 are submitted.
SPEC = {"flow": "laplacian", "iterations": 10000}


class Postgres:
    """A PostgreSQL server of its own in a new temporary directory, on a free loopback port,
    trusting local connections; uri names its database. stop() removes it all."""

    def __init__(self):
        self.as_user = []
        self.dir = os.path.realpath(tempfile.mkdtemp(prefix="meshsmooth-pg-"))
        if os.geteuid() == 0:  # initdb refuses root: the cluster is the postgres user's
            os.chown(self.dir, pwd.getpwnam("postgres").pw_uid, -1)
            self.as_user = ["runuser", "-u", "postgres", "--"]
        self.port = free_port()
        data = os.path.join(self.dir, "data")
        r = run(self.as_user + [f"{PG_BIN}/initdb", "-D", data, "-A", "trust", "-U", "ms"], timeout=60)
        require(r.returncode == 0, f"initdb failed: {r.stdout} {r.stderr}")
        r = run(self.as_user + [f"{PG_BIN}/pg_ctl", "-D", data, "-o",
                                f"-c listen_addresses=127.0.0.1 -p {self.port} -k {self.dir} -c fsync=off",
                                "-l", os.path.join(self.dir, "log"), "-w", "start"], timeout=60)
        require(r.returncode == 0, f"pg_ctl start failed: {r.stdout} {r.stderr}")
        self.uri = f"postgresql://ms@127.0.0.1:{self.port}/postgres"

    def stop(self):
        if self.dir is None:
            return
        run(self.as_user + [f"{PG_BIN}/pg_ctl", "-D", os.path.join(self.dir, "data"), "-m", "immediate", "stop"],
            timeout=30)
        shutil.rmtree(self.dir, ignore_errors=True)
        self.dir = None


def scrape(server):
    with urllib.request.urlopen(f"http://{server.metrics_address}/metrics", timeout=10) as r:
        return parse_metrics(r.read().decode())


def check_one_replica(a, pb2, pb2_grpc, tmp, pg, mesh):
    """Submit (cut, then resumed), watch to SUCCEEDED, fetch, delete, through one replica."""
    with Server(a.server, "--workers", "1", "--job-store", pg.uri, stderr=os.path.join(tmp, "one.log")) as s:
        c = Client(pb2, pb2_grpc, s.address)
        spec = c.spec(SPEC)
        try:
            c.submit("one-1", spec, mesh, cut_at=len(mesh) // 2, chunk=2048)
        except grpc.RpcError:
            pass
        held = c.stub.QueryUpload(pb2.QueryUploadRequest(request_id="one-1"), timeout=DEADLINE_S)
        require(0 < held.bytes_received < len(mesh), f"held {held.bytes_received} of {len(mesh)}")
        sub = c.submit("one-1", spec, mesh, offset=held.bytes_received, chunk=2048)
        require(sub.committed, f"resumed submit: {sub}")
        events = list(c.stub.WatchJob(pb2.WatchJobRequest(job_id=sub.job.job_id), timeout=DEADLINE_S))
        require(events[-1].job.state == pb2.JOB_STATE_SUCCEEDED, f"last event {events[-1]}")
        job = c.get(sub.job.job_id)
        require(job.attempts == 1, f"attempts {job.attempts}")
        got, msgs = c.fetch(job.job_id)
        require(got == c.smooth(spec, mesh) and msgs[0].sha256 == hashlib.sha256(got).digest(), "not Smooth's bytes")
        again = c.submit("one-1", spec, mesh)
        require(again.job.job_id == job.job_id, "the same submit again is the same job")
        c.stub.DeleteJob(pb2.DeleteJobRequest(job_id=job.job_id), timeout=DEADLINE_S)
        code, _ = code_of(lambda: c.get(job.job_id))
        require(code == grpc.StatusCode.NOT_FOUND, f"a deleted job: {code}")
        c.close()


def watch(c, job_id, out):
    """WatchJob's events for job_id into out (a list), or the error."""
    try:
        out.extend(c.stub.WatchJob(c.pb2.WatchJobRequest(job_id=job_id), timeout=120))
    except grpc.RpcError as e:
        out.append(e)


def runner_of(logs, job_id):
    """The replica whose log has job_id's successful run."""
    ran = [i for i, lines in enumerate(logs) if (job_id, "OK") in lines]
    require(len(ran) == 1, f"job {job_id} ran OK on replicas {ran}")
    return ran[0]


def check_replicas(a, pb2, pb2_grpc, tmp, pg, meshes):
    """60 jobs round-robin over 3 replicas, one SIGKILLed mid-run; see the module's docstring."""
    servers, clients = [], []
    try:
        for i in range(REPLICAS):
            servers.append(Server(a.server, "--workers", "1", "--job-store", pg.uri, "--job-lease", f"{LEASE_S:g}s",
                                  "--metrics-listen", "127.0.0.1:0", stderr=os.path.join(tmp, f"replica-{i}.log")))
            clients.append(Client(pb2, pb2_grpc, servers[-1].address))
        spec = clients[0].spec(SPEC)
        ids = []
        for n in range(JOBS):
            sub = clients[n % REPLICAS].submit(f"many-{n}", spec, meshes[n % len(meshes)])
            require(sub.committed, f"submit {n}: {sub}")
            ids.append(sub.job.job_id)
        watched = {i: [] for i in ids[:6]}
        threads = [threading.Thread(target=watch, args=(clients[2], i, watched[i]), daemon=True) for i in watched]
        for t in threads:
            t.start()
        # Kill replica 1 while every replica runs a job (one worker each: three RUNNING).
        t_end = time.time() + 60
        while len(clients[0].stub.ListJobs(pb2.ListJobsRequest(states=[pb2.JOB_STATE_RUNNING]),
                                           timeout=DEADLINE_S).jobs) < REPLICAS:
            require(time.time() < t_end, "three jobs never ran at once")
            time.sleep(0.01)
        servers[1].proc.kill()
        t_kill = time.time()
        servers[1].stop()
        survivors = [0, 2]
        takeover_s = None
        t_end = time.time() + 120
        while True:
            jobs = [j for j in clients[0].stub.ListJobs(pb2.ListJobsRequest(page_size=1000), timeout=DEADLINE_S).jobs
                    if j.request_id.startswith("many-")]
            if takeover_s is None and any(j.attempts >= 2 for j in jobs):
                takeover_s = time.time() - t_kill
            if sum(j.state == pb2.JOB_STATE_SUCCEEDED for j in jobs) == JOBS or time.time() > t_end:
                break
            time.sleep(0.05)
        jobs = {j.job_id: j for j in jobs}
        states = sorted({pb2.JobState.Name(j.state) for j in jobs.values()})
        require(len(jobs) == JOBS and states == ["JOB_STATE_SUCCEEDED"], f"{len(jobs)} jobs, states {states}")
        print(f"takeover {takeover_s:.2f} s after the SIGKILL (lease {LEASE_S:g} s)", flush=True)
        require(takeover_s is not None and takeover_s <= LEASE_S + 2.0, f"takeover after {takeover_s} s")
        # Each run once per attempt: the runs logged, plus the runs the SIGKILL cut (the takeovers).
        logs = [set(s.job_lines()) for s in servers]
        runs = {i: sum(1 for s in servers for j, _ in s.job_lines() if j == i) for i in ids}
        samples = [scrape(servers[i]) for i in survivors]
        takeovers = sum(metric_sum(s, "meshsmooth_job_lease_takeovers_total") for s in samples)
        taken = [i for i in ids if jobs[i].attempts == 2]
        require(takeovers >= 1 and takeovers == len(taken), f"{takeovers} takeovers counted, {len(taken)} taken")
        require(all(jobs[i].attempts == runs[i] + (i in taken) for i in ids),
                f"attempts vs runs: {[(jobs[i].attempts, runs[i]) for i in ids if jobs[i].attempts != runs[i]]}")
        require(all(jobs[i].attempts in (1, 2) for i in ids), "a job ran more than twice")
        print("runs by replica: " + ", ".join(f"{r}: {sum(runner_of(logs, i) == r for i in ids)}"
                                                for r in range(REPLICAS)), flush=True)
        # Results from a replica other than the one that ran them, byte-equal to Smooth's.
        want = [clients[0].smooth(spec, m) for m in meshes]
        for n, i in enumerate(ids):
            ran = runner_of(logs, i)
            other = next(r for r in survivors if r != ran)
            got, _ = clients[other].fetch(i)
            require(got == want[n % len(meshes)], f"job {i} (ran on {ran}) fetched from {other}: not Smooth's bytes")
        # Watches on replica 2 followed jobs that other replicas ran.
        for t in threads:
            t.join(timeout=30)
        elsewhere = 0
        for i, events in watched.items():
            require(events and not isinstance(events[-1], grpc.RpcError), f"watch of {i}: {events[-1:]}")
            seqs = [e.sequence for e in events]
            require(seqs == sorted(set(seqs)) and events[-1].job.state == pb2.JOB_STATE_SUCCEEDED,
                    f"watch of {i}: {seqs}, last {events[-1].job.state}")
            elsewhere += runner_of(logs, i) != 2
        require(elsewhere >= 1, "no watched job ran on another replica")
        # The queue metrics: the whole store's, the same from each replica.
        for s in samples:
            require(metric_sum(s, "meshsmooth_job_store_jobs", state="succeeded") == JOBS,
                    metric_sum(s, "meshsmooth_job_store_jobs", state="succeeded"))
            require(metric_sum(s, "meshsmooth_job_store_queue_depth") == 0, "queue depth")
            require(metric_sum(s, "meshsmooth_job_store_oldest_queued_seconds") == 0, "oldest queued")
        for c in clients:
            c.close()
        return takeover_s
    finally:
        for s in servers:
            s.stop()


def check_queue_metrics(a, pb2, pb2_grpc, tmp, pg, mesh, big):
    """Queued jobs show in the depth and the oldest one's age (a server that runs none of them:
    its one worker on a long job, many seconds on `big`)."""
    with Server(a.server, "--workers", "1", "--max-iterations", "100000", "--job-store", pg.uri,
                "--metrics-listen", "127.0.0.1:0", stderr=os.path.join(tmp, "queue.log")) as s:
        c = Client(pb2, pb2_grpc, s.address)
        long_job = c.submit("queue-long", c.spec({"flow": "laplacian", "iterations": 100000}), big).job.job_id
        c.wait_state(long_job, ["JOB_STATE_RUNNING"])
        queued = [c.submit(f"queue-{n}", c.spec(SPEC), mesh).job.job_id for n in range(3)]
        time.sleep(1.2)
        m = scrape(s)
        require(metric_sum(m, "meshsmooth_job_store_queue_depth") == 3, metric_sum(m, "meshsmooth_job_store_queue_depth"))
        require(metric_sum(m, "meshsmooth_job_store_jobs", state="queued") == 3, "jobs{state=queued}")
        require(metric_sum(m, "meshsmooth_job_store_jobs", state="running") == 1, "jobs{state=running}")
        age = metric_sum(m, "meshsmooth_job_store_oldest_queued_seconds")
        require(1.0 <= age < 30, f"oldest queued {age} s")
        for i in [long_job] + queued:
            c.stub.CancelJob(pb2.CancelJobRequest(job_id=i), timeout=DEADLINE_S)
        c.close()


def main():
    ap = parser(__doc__, required=("server", "proto-root"))
    a = ap.parse_args()
    if not os.path.isfile(f"{PG_BIN}/initdb"):
        print(f"skip: no PostgreSQL binaries in {PG_BIN} (apt-get install postgresql-15)", flush=True)
        return 1 if os.environ.get("CI") == "true" else 77

    def body(checks, tmp):
        pg = checks.check("a throwaway PostgreSQL started", Postgres)
        if pg is None:
            return
        try:
            pb2, pb2_grpc = checks.check("python stubs generated from the proto", generate_stubs, a.proto_root, tmp)
            meshes = checks.check("6 noisy icospheres as Draco", make_meshes, tmp, 6, 3)
            checks.check("one replica: submit cut and resumed, watch, fetch = Smooth, delete",
                         check_one_replica, a, pb2, pb2_grpc, tmp, pg, meshes[0])
            checks.check(f"{REPLICAS} replicas, {JOBS} jobs, one SIGKILLed: all SUCCEEDED, runs = attempts, "
                         f"a takeover within the lease + 2 s, results from another replica = Smooth",
                         check_replicas, a, pb2, pb2_grpc, tmp, pg, meshes)
            big = checks.check("a larger icosphere as Draco", make_meshes, tmp, 1, 4)
            checks.check("queue metrics: depth, oldest queued job, jobs by state",
                         check_queue_metrics, a, pb2, pb2_grpc, tmp, pg, meshes[0], big[0])
        finally:
            pg.stop()

    return run_checks(body, tmp_prefix="meshsmooth-jobs-pg-")


if __name__ == "__main__":
    raise SystemExit(main())
