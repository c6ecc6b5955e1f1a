#!/usr/bin/python3
"""meshsmoothd as one replica of many, driven as a user runs it: the CLI's --server lists with
round-robin, its retries (a replica down, a saturated replica), client-chosen job ids, and the
server's side of it: SIGTERM (health NOT_SERVING at once, new jobs refused, exit within the
grace + 1 s) and --max-queue-wait.

Run by ctest: replicas_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd
Prints one line per check and ends with 'N passed, M failed'.
"""
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
import urllib.request

import grpc

from harness import Server, free_port, metric_sum, parse_metrics, parser, run, run_checks


class Replica(Server):
    """One meshsmoothd on a free loopback port; its stderr lines are kept."""

    def __init__(self, binary, *flags):
        super().__init__(binary, *flags, stderr=Server.KEEP)

    def jobs(self, status=None):
        """The job ids of the server's log lines, optionally only those with `status`."""
        return [jid for jid, st in self.job_lines() if status is None or st == status]


def wait_for_gauge(rep, name, value, timeout=30.0):
    """Polls the replica's /metrics (it runs with --metrics-listen) until the gauge `name` reads `value`."""
    deadline = time.monotonic() + timeout
    while True:
        with urllib.request.urlopen(f"http://{rep.metrics_address}/metrics", timeout=10) as r:
            now = metric_sum(parse_metrics(r.read().decode()), name)
        if now == value:
            return
        assert time.monotonic() < deadline, f"{name} is {now}, not {value}, after {timeout:g} s"
        time.sleep(0.02)


def main():
    a = parser(__doc__, required=("cli", "server")).parse_args()
    return run_checks(lambda checks, tmp: replica_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-replicas-")


def replica_checks(a, check, tmp):
    """Every check, in order; the files they write go to tmp."""
    cli, server = a.cli, a.server

    def smooth(address, *extra, out="out.ply", timeout=120):
        return run([cli, "smooth", "builtin:noisy-sphere", "-o", os.path.join(tmp, out), "--iterations", "3",
                    "--server", address, *extra], timeout=timeout)

    # A job that keeps one worker busy for a few seconds: Taubin neither shrinks nor diverges.
    def busy(address, iterations):
        return subprocess.Popen([cli, "smooth", "builtin:noisy-sphere-large", "-o", os.path.join(tmp, "busy.ply"),
                                 "--flow", "taubin", "--iterations", iterations, "--server", address, "--quiet"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    # The same, returned once it holds the replica's only worker (read from its /metrics).
    def busy_running(rep, iterations):
        b = busy(rep.address, iterations)
        wait_for_gauge(rep, "meshsmooth_jobs_running", 1)
        return b

    def help_documents_flags():
        r = run([cli, "smooth", "--help"])
        assert r.returncode == 0, r.returncode
        for word in ("--retries", "--job-id", "dns:///", "ipv4:", "round-robin"):
            assert word in r.stdout, f"'{word}' missing from smooth --help"
    check("smooth --help documents --retries, --job-id and the target forms", help_documents_flags)

    def bad_targets():
        for target in ("host-a:50051,host-b:50051", "127.0.0.1:5,[::1]:6", "127.0.0.1:x,127.0.0.1:2"):
            r = smooth(target)
            assert r.returncode == 2, (target, r.returncode, r.stderr)
            assert "--server" in r.stderr, (target, r.stderr)
    check("a --server list naming a host, mixing families or without a port exits 2 naming --server", bad_targets)

    one = Replica(server, "--workers", "1")
    two = Replica(server, "--workers", "1")
    try:
        def job_id_everywhere():
            r = smooth(one.address, "--job-id", "scan-0042/turntable:7", "--json")
            assert r.returncode == 0, r.stderr
            assert json.loads(r.stdout)["job_id"] == "scan-0042/turntable:7", r.stdout
            r = smooth(one.address, "--job-id", "scan-0043")
            assert r.returncode == 0, r.stderr
            assert r.stdout.startswith("job scan-0043: "), r.stdout
            time.sleep(0.2)
            assert one.jobs("OK")[-2:] == ["scan-0042/turntable:7", "scan-0043"], one.jobs()
            # Without --job-id the server makes one up, "<hex>-<n>".
            r = smooth(one.address, "--json")
            assert r.returncode == 0, r.stderr
            assert re.fullmatch(r"[0-9a-f]+-\d+", json.loads(r.stdout)["job_id"]), r.stdout
        check("--job-id is the job's id in the summary, the CLI's report and the server's log", job_id_everywhere)

        def bad_job_ids():
            for job_id, words in (("two words", ["job_id", "byte 32"]), ("x" * 129, ["job_id", "129", "128"]),
                                  ("caf\u00e9", ["job_id", "byte 195"])):
                r = smooth(one.address, "--job-id", job_id)
                assert r.returncode == 1, (job_id, r.returncode, r.stderr)
                assert "INVALID_ARGUMENT" in r.stderr and "retrying" not in r.stderr, (job_id, r.stderr)
                for w in words:
                    assert w in r.stderr, (job_id, w, r.stderr)
            r = smooth(one.address, "--job-id", "x" * 128)
            assert r.returncode == 0, r.stderr
        check("a job id with a space, above 128 characters or not ASCII is INVALID_ARGUMENT naming job_id, "
              "not retried", bad_job_ids)

        def one_replica_down():
            down = f"127.0.0.1:{free_port()}"
            before = len(one.jobs("OK"))
            for i in range(4):
                r = smooth(f"{down},{one.address}", "--job-id", f"down-{i}", "--timeout", "30")
                assert r.returncode == 0, (i, r.returncode, r.stderr)
            assert one.jobs("OK")[before:] == [f"down-{i}" for i in range(4)], one.jobs()
        check("with one address of the list down, every job runs on the other", one_replica_down)

        def round_robin_spreads():
            counts = [len(one.jobs()), len(two.jobs())]
            for i in range(16):
                target = f"{one.address},{two.address}" if i % 2 else f"ipv4:{one.address},{two.address}"
                r = smooth(target, "--job-id", f"rr-{i}")
                assert r.returncode == 0, (i, r.stderr)
            time.sleep(0.2)
            got = [len(one.jobs()) - counts[0], len(two.jobs()) - counts[1]]
            assert sum(got) == 16, got
            # Each one-job CLI picks a replica at random: 16 jobs leave fewer than 2 on one of
            # them with a probability of 0.05 %.
            assert min(got) >= 2, f"jobs per replica {got}"
            ids = sorted(one.jobs()[counts[0]:] + two.jobs()[counts[1]:])
            assert ids == sorted(f"rr-{i}" for i in range(16)), ids
        check("a list of two replicas spreads one-job CLIs over both (server logs), each job once",
              round_robin_spreads)
    finally:
        one.stop()
        two.stop()

    saturated = Replica(server, "--workers", "1", "--queue-depth", "0", "--metrics-listen", "127.0.0.1:0")
    try:
        def retried_until_a_worker_is_free():
            b = busy_running(saturated, "10000")  # the only worker; the queue takes none
            try:
                p = subprocess.Popen([cli, "smooth", "builtin:noisy-sphere", "-o", os.path.join(tmp, "patient.ply"),
                                      "--iterations", "3", "--server", saturated.address, "--retries", "12",
                                      "--job-id", "patient"],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                first = p.stderr.readline()  # the first refusal; then the worker is freed
                assert "attempt 1 failed (RESOURCE_EXHAUSTED: the job queue is full" in first, first
                b.kill()  # a client that goes away frees its worker at once
                out, err = p.communicate(timeout=120)
                assert p.returncode == 0, (p.returncode, first + err)
                time.sleep(0.2)
                assert saturated.jobs("OK").count("patient") == 1, saturated.jobs()
            finally:
                b.kill()
                b.wait(timeout=120)
        check("a saturated replica: RESOURCE_EXHAUSTED, then success after retries, the job run once",
              retried_until_a_worker_is_free)

        def retries_are_bounded():
            b = busy_running(saturated, "10000")
            try:
                r = smooth(saturated.address, "--retries", "0")
                assert r.returncode == 1, (r.returncode, r.stderr)
                assert "RESOURCE_EXHAUSTED: the job queue is full" in r.stderr and "retrying" not in r.stderr, r.stderr
                t0 = time.monotonic()
                r = smooth(saturated.address, "--retries", "2")
                assert r.returncode == 1, (r.returncode, r.stderr)
                retries = re.findall(r"attempt (\d) failed \(RESOURCE_EXHAUSTED", r.stderr)
                assert retries == ["1", "2"], r.stderr
                assert r.stderr.rstrip().endswith("RESOURCE_EXHAUSTED: the job queue is full (0 jobs waiting); "
                                                  "retry later"), r.stderr
                assert time.monotonic() - t0 < 10, "two waits of at most 0.2 s and 0.4 s"
                # The deadline bounds the retries too: 20 retries do not outlast --timeout 2.
                t0 = time.monotonic()
                r = smooth(saturated.address, "--retries", "20", "--timeout", "2")
                assert r.returncode == 1 and "RESOURCE_EXHAUSTED" in r.stderr, (r.returncode, r.stderr)
                assert time.monotonic() - t0 < 4, time.monotonic() - t0
            finally:
                b.kill()
                b.wait()
        check("--retries 0 does not retry; --retries 2 makes 3 attempts, then the last status; --timeout bounds them",
              retries_are_bounded)
    finally:
        saturated.stop()

    def busy_port_is_refused():
        with Replica(server, "--workers", "1") as first:
            # The port is taken: the second server must not start and share it.
            r = run([server, "--listen", first.address, "--workers", "1"], timeout=30)
            assert r.returncode != 0, (r.returncode, r.stdout, r.stderr)
            assert "listening" not in r.stdout, r.stdout
            assert "address in use" in r.stderr and first.address in r.stderr, r.stderr
            # The first one serves on.
            res = smooth(first.address, "--job-id", "after-busy-port")
            assert res.returncode == 0, res.stderr
            time.sleep(0.2)
            assert first.jobs("OK") == ["after-busy-port"], first.jobs()
    check("a second meshsmoothd on a port another one holds exits non-zero with 'address in use'; the first serves "
          "on", busy_port_is_refused)

    def limits_the_mesh_exceeds_are_not_retried():
        # builtin:noisy-sphere has 2562 vertices and uploads some 60 KB.
        for flag, value in (("--max-vertices", "1000"), ("--max-upload-bytes", "10000")):
            with Replica(server, "--workers", "1", flag, value) as rep:
                job_id = f"too-big{flag}"
                r = smooth(rep.address, "--retries", "4", "--job-id", job_id)
                assert r.returncode == 1, (flag, r.returncode, r.stderr)
                assert "retrying" not in r.stderr and "attempt" not in r.stderr, (flag, r.stderr)
                assert "RESOURCE_EXHAUSTED" in r.stderr and flag in r.stderr, (flag, r.stderr)
                time.sleep(0.2)
                # One call reached the server: one log line names the job.
                named = [line for line in rep.stderr_lines() if job_id in line]
                assert len(named) == 1, (flag, named)
    check("a mesh above --max-vertices or --max-upload-bytes: one upload, exit 1, the message names the limit",
          limits_the_mesh_exceeds_are_not_retried)

    def health_statuses(address, into):
        """Watches grpc.health.v1 (service "") on a thread: (time, status) pairs into `into`;
        1 SERVING, 2 NOT_SERVING. The messages are encoded by hand: one enum field, number 1."""
        channel = grpc.insecure_channel(address)
        watch = channel.unary_stream("/grpc.health.v1.Health/Watch", request_serializer=lambda b: b,
                                     response_deserializer=lambda b: b)

        def loop():
            try:
                for resp in watch(b"", timeout=60):
                    into.append((time.monotonic(), resp[1] if len(resp) >= 2 and resp[0] == 0x08 else 0))
            except grpc.RpcError:
                pass
        threading.Thread(target=loop, daemon=True).start()
        return channel

    def sigterm_drains():
        # The grace is ~5x the short job's run alone: under ASan beside another test, the short
        # job shares two cores with the long one and the CLIs, and took over 6 s on a CI machine.
        grace = 12.0
        rep = Replica(server, "--workers", "2", "--threads-per-job", "1", "--grace-seconds", str(grace),
                      "--metrics-listen", "127.0.0.1:0")
        statuses = []
        channel = health_statuses(rep.address, statuses)
        try:
            for _ in range(100):
                if statuses:
                    break
                time.sleep(0.05)
            assert statuses and statuses[-1][1] == 1, f"health before SIGTERM: {statuses}"

            def job(flow, iterations, job_id):
                return subprocess.Popen([cli, "smooth", "builtin:noisy-sphere-large", "-o", os.path.join(tmp, job_id + ".ply"),
                                         "--flow", flow, "--iterations", iterations, "--server", rep.address,
                                         "--retries", "0", "--job-id", job_id, "--quiet"],
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            # The short job is sized to ~2.5 s on this machine: 1,000 iterations timed.
            t = time.monotonic()
            calib = job("taubin", "1000", "calibration")
            calib.wait(timeout=120)
            assert calib.returncode == 0, calib.stderr.read()
            short_iterations = max(200, min(10000, int(1000 * 2.5 / max(time.monotonic() - t, 1e-3))))
            # guided_normal at the server's 10,000 iterations: minutes, far beyond the grace however
            # fast the machine (median's ~8 s on two cores came close); the grace cuts it.
            long_job = job("guided_normal", "10000", "long")
            short_job = job("taubin", str(short_iterations), "short")   # finishes within it
            # The queued job is sent only once both workers are busy, and SIGTERM only once it waits:
            # under load (ASan, a busy CI machine) a CLI takes a varying time to upload.
            wait_for_gauge(rep, "meshsmooth_jobs_running", 2)
            queued_job = job("median", "10000", "queued")
            wait_for_gauge(rep, "meshsmooth_queue_depth", 1)
            assert short_job.poll() is None, "the short job ended before SIGTERM: make it longer"
            t0 = time.monotonic()
            rep.proc.send_signal(signal.SIGTERM)
            r = smooth(rep.address, "--retries", "0", "--job-id", "after")
            new_seconds = time.monotonic() - t0
            assert r.returncode == 3 and "UNAVAILABLE" in r.stderr and "shutting down" in r.stderr, (r.returncode, r.stderr)
            queued_job.wait(timeout=30)
            queued_seconds = time.monotonic() - t0
            short_job.wait(timeout=30)
            long_job.wait(timeout=30)
            rc = rep.proc.wait(timeout=30)
            exit_seconds = time.monotonic() - t0
            not_serving = [t - t0 for t, st in statuses if st == 2]
            print(f"  SIGTERM with --grace-seconds {grace:g} (short job {short_iterations} iterations): NOT_SERVING after "
                  f"{not_serving[0] * 1000 if not_serving else float('nan'):.0f} ms, a new job refused after "
                  f"{new_seconds:.2f} s, the queued job after {queued_seconds:.2f} s, exit {rc} after "
                  f"{exit_seconds:.2f} s", flush=True)
            assert not_serving and not_serving[0] <= 0.1, f"health after SIGTERM: {statuses}"
            q_err = queued_job.stderr.read()
            assert queued_job.returncode == 3 and "UNAVAILABLE" in q_err and "did not start" in q_err, q_err
            assert queued_seconds < 1.5, queued_seconds
            assert short_job.returncode == 0, short_job.stderr.read()
            l_err = long_job.stderr.read()
            assert long_job.returncode == 3 and "UNAVAILABLE" in l_err and "grace" in l_err, l_err
            assert rc == 1, f"exit status {rc}: the grace cut the long job, which the status must say"
            assert grace - 0.1 <= exit_seconds <= grace + 1.0, exit_seconds
            time.sleep(0.2)
            assert rep.jobs("OK") == ["calibration", "short"], rep.jobs()
        finally:
            channel.close()
            rep.stop()
    check("SIGTERM: health NOT_SERVING within 100 ms, new and queued jobs UNAVAILABLE at once, a running job "
          "finishes within the grace, the rest UNAVAILABLE, exit 1 within grace + 1 s", sigterm_drains)

    def max_queue_wait():
        rep = Replica(server, "--workers", "1", "--threads-per-job", "1", "--max-queue-wait", "0.5",
                      "--metrics-listen", "127.0.0.1:0")
        try:
            b = busy_running(rep, "10000")
            try:
                t0 = time.monotonic()
                r = smooth(rep.address, "--retries", "0", "--job-id", "impatient")
                waited = time.monotonic() - t0
                print(f"  --max-queue-wait 0.5: refused after {waited:.2f} s", flush=True)
                assert r.returncode == 1, (r.returncode, r.stderr)
                assert "RESOURCE_EXHAUSTED" in r.stderr and "--max-queue-wait" in r.stderr, r.stderr
                assert 0.5 <= waited < 2.5, waited
            finally:
                b.kill()
                b.wait()
        finally:
            rep.stop()
    check("--max-queue-wait: a job that finds no worker in time gets RESOURCE_EXHAUSTED naming the flag",
          max_queue_wait)


if __name__ == "__main__":
    sys.exit(main())
