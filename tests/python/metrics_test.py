#!/usr/bin/python3
"""meshsmoothd's operations surface as an operator meets it: --metrics-listen (off by default)
serves Prometheus's text format that promtool accepts; after jobs of known sizes the counters
and histogram counts equal the jobs and the vertex counter their sum; refusals are counted by
reason; --log-format json writes one JSON object a line (every line parses) with the job's
fields and the lifecycle events.

Run by ctest: metrics_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd
Needs promtool (Debian's prometheus package). Prints one line per check and ends with
'N passed, M failed'.
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import urllib.request

from harness import Server, metric_sum, parse_metrics, parser, require, run, run_checks, write_text

# (builtin input, its vertices, extra flags): five jobs, one of them with automatic stopping.
JOBS = [
    ("builtin:noisy-sphere", 2562, ["--iterations", "3"]),
    ("builtin:sphere", 2562, ["--iterations", "2", "--flow", "taubin"]),
    ("builtin:noisy-sphere-large", 40962, ["--iterations", "2", "--flow", "laplacian"]),
    ("builtin:noisy-sphere", 2562, ["--iterations", "4", "--flow", "laplacian"]),
    ("builtin:noisy-sphere", 2562, ["--iterations", "auto", "--flow", "bilaplacian"]),
]
STEPS = ("queue", "decode", "smooth", "encode")
JOB_FIELDS = {"time": str, "level": str, "event": str, "message": str, "job_id": str, "flow": str, "vertices": int,
              "iterations": int, "stop_reason": str, "status": str, "peer": str, "queue_seconds": (int, float),
              "decode_seconds": (int, float), "smooth_seconds": (int, float), "encode_seconds": (int, float),
              "total_seconds": (int, float)}


def scrape(address):
    with urllib.request.urlopen(f"http://{address}/metrics", timeout=10) as r:
        require(r.status == 200, f"GET /metrics: HTTP {r.status}")
        require(r.headers.get("Content-Type", "").startswith("text/plain"), r.headers.get("Content-Type"))
        return r.read().decode()


def main():
    a = parser(__doc__, required=("cli", "server")).parse_args()
    return run_checks(lambda checks, tmp: metrics_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-metrics-")


def metrics_checks(a, check, tmp):
    def help_documents_flags():
        r = run([a.server, "--help"])
        assert r.returncode == 0, r.returncode
        for word in ("--metrics-listen", "--log-format", "json", "/metrics"):
            assert word in r.stdout, f"'{word}' missing from meshsmoothd --help"
        r = run([a.server, "--log-format", "xml"])
        assert r.returncode == 2 and "--log-format" in r.stderr, (r.returncode, r.stderr)
    check("meshsmoothd --help documents --metrics-listen and --log-format; a bad --log-format exits 2",
          help_documents_flags)

    def off_by_default():
        with Server(a.server) as s:
            assert s.metrics_address is None, s.metrics_address
    check("without --metrics-listen there is no metrics endpoint", off_by_default)

    def bad_address():
        r = run([a.server, "--listen", "127.0.0.1:0", "--metrics-listen", "256.0.0.1:1"], timeout=30)
        assert r.returncode == 1 and "metrics" in r.stderr, (r.returncode, r.stderr)
    check("a --metrics-listen address that cannot be bound: exit 1 naming the metrics", bad_address)

    server = Server(a.server, "--metrics-listen", "127.0.0.1:0", "--log-format", "json", "--workers", "1",
                    stderr=Server.KEEP)
    try:
        require(server.metrics_address is not None, "no 'meshsmoothd metrics on' line")

        def before_jobs():
            s = parse_metrics(scrape(server.metrics_address))
            for name in ("meshsmooth_queue_depth", "meshsmooth_jobs_running", "meshsmooth_buffered_bytes",
                         "meshsmooth_vertices_processed_total", "meshsmooth_upload_bytes_total"):
                assert metric_sum(s, name) == 0, (name, metric_sum(s, name))
            assert metric_sum(s, "meshsmooth_workers") == 1
            assert metric_sum(s, "meshsmooth_queue_capacity") == 64
            assert metric_sum(s, "process_resident_memory_bytes") > 1 << 20
            # Present, and not negative: a process that has just started may have used less CPU
            # than one clock tick (/proc's unit); after the jobs it has used some (below).
            assert any(n == "process_cpu_seconds_total" for n, _ in s), "no process_cpu_seconds_total"
            assert metric_sum(s, "process_cpu_seconds_total") >= 0
            assert abs(metric_sum(s, "process_start_time_seconds") - time.time()) < 600
        check("before any job: the gauges and counters are 0, the process's memory and CPU are there",
              before_jobs)

        def run_jobs():
            for i, (mesh, _, flags) in enumerate(JOBS):
                r = run([a.cli, "smooth", mesh, "-o", os.path.join(tmp, f"out{i}.ply"), "--server", server.address,
                         "--quiet", *flags])
                assert r.returncode == 0, (mesh, r.stderr)
            # A spec the server refuses: a refusal, not a job.
            r = run([a.cli, "smooth", "builtin:noisy-sphere", "-o", os.path.join(tmp, "bad.ply"), "--server",
                     server.address, "--iterations", "20000", "--quiet", "--retries", "0"])
            assert r.returncode != 0 and "INVALID_ARGUMENT" in r.stderr, (r.returncode, r.stderr)
        check(f"{len(JOBS)} jobs of known sizes succeed and one spec is refused", run_jobs)

        text = scrape(server.metrics_address)
        with open(os.path.join(tmp, "metrics.txt"), "w") as f:
            f.write(text)

        def promtool_accepts():
            promtool = shutil.which("promtool")
            assert promtool, "promtool not found (scripts/setup.sh installs Debian's prometheus)"
            r = subprocess.run([promtool, "check", "metrics"], input=text, capture_output=True, text=True, timeout=60)
            print(f"  promtool check metrics: exit {r.returncode} {(r.stdout + r.stderr).strip()!r}", flush=True)
            assert r.returncode == 0 and not (r.stdout + r.stderr).strip(), r.stdout + r.stderr
        check("GET /metrics passes promtool check metrics with no finding", promtool_accepts)

        def counts_equal_jobs():
            s = parse_metrics(text)
            n, vertices = len(JOBS), sum(v for _, v, _ in JOBS)
            assert metric_sum(s, "meshsmooth_jobs_total") == n, metric_sum(s, "meshsmooth_jobs_total")
            assert metric_sum(s, "meshsmooth_jobs_total", status="OK") == n
            assert metric_sum(s, "meshsmooth_jobs_total", flow="laplacian", status="OK") == 2
            for step in STEPS:
                got = metric_sum(s, "meshsmooth_job_duration_seconds_count", step=step)
                assert got == n, (step, got)
                assert metric_sum(s, "meshsmooth_job_duration_seconds_bucket", step=step, le="+Inf") == n, step
                assert metric_sum(s, "meshsmooth_job_duration_seconds_sum", step=step) > 0, step
            assert metric_sum(s, "meshsmooth_vertices_processed_total") == vertices, \
                (metric_sum(s, "meshsmooth_vertices_processed_total"), vertices)
            assert metric_sum(s, "meshsmooth_iterations_total") >= 3 + 2 + 2 + 4 + 1
            assert metric_sum(s, "meshsmooth_auto_iterations_count") == 1
            assert metric_sum(s, "meshsmooth_auto_stops_total") == 1
            assert metric_sum(s, "meshsmooth_refusals_total", reason="invalid_request") == 1
            assert metric_sum(s, "meshsmooth_refusals_total") == 1
            assert metric_sum(s, "meshsmooth_upload_bytes_total") > 10000
            assert metric_sum(s, "process_cpu_seconds_total") > 0
            assert metric_sum(s, "meshsmooth_queue_depth") == 0 and metric_sum(s, "meshsmooth_jobs_running") == 0
            ids = [k for k in s if "job" in dict(k[1]) or "job_id" in dict(k[1])]
            assert not ids, f"a job label: {ids[:3]}"
        check(f"after {len(JOBS)} jobs: jobs_total and every step's histogram count are {len(JOBS)}, the vertex "
              f"counter is their sum ({sum(v for _, v, _ in JOBS)}), one automatic stop, one refusal",
              counts_equal_jobs)
    finally:
        server.proc.send_signal(signal.SIGTERM)
        rc, killed = server.stop()

    def json_log():
        assert rc == 0 and not killed, (rc, killed)
        lines = server.stderr_lines()
        entries = [json.loads(line) for line in lines]  # every line parses
        jobs = [e for e in entries if e.get("event") == "job"]
        assert len(jobs) == len(JOBS), [e.get("event") for e in entries]
        for e in jobs:
            for field, kind in JOB_FIELDS.items():
                assert isinstance(e.get(field), kind), (field, e)
            assert e["status"] == "OK" and e["level"] == "info" and e["peer"].startswith("ipv4:127.0.0.1:"), e
            assert e["time"].endswith("Z") and "T" in e["time"], e["time"]
        assert sorted(e["vertices"] for e in jobs) == sorted(v for _, v, _ in JOBS)
        # One type on every line: the count asked for, 0 for automatic (JobSpec.iterations).
        assert [e["iterations_asked"] for e in jobs] == [3, 2, 2, 4, 0], [e["iterations_asked"] for e in jobs]
        assert all(type(e["iterations_asked"]) is int for e in jobs), jobs
        assert jobs[4]["stop_reason"] and jobs[0]["stop_reason"] == "iterations", jobs
        events = [e["event"] for e in entries if e.get("event") != "job"]
        assert events[0] == "listening" and events[-2:] == ["shutdown", "stopped"], events
        assert entries[-1]["jobs_cut"] == 0 and entries[-2]["signal"] == "SIGTERM", entries[-2:]
    check("--log-format json: every stderr line is a JSON object; one per job with its fields, and the lifecycle "
          "events listening, shutdown, stopped", json_log)

    token = write_text(os.path.join(tmp, "server.token"), "s3cret\n")
    wrong = write_text(os.path.join(tmp, "wrong.token"), "guess\n")
    guarded = Server(a.server, "--metrics-listen", "127.0.0.1:0", "--log-format", "json", "--workers", "1",
                     "--auth-token-file", token, "--max-vertices", "1000", stderr=Server.KEEP)
    try:
        def refused_and_failed_calls():
            def cli(*args, token_file=token):
                return run([a.cli, *args, "--server", guarded.address, "--token-file", token_file, "--retries", "0"])
            out = os.path.join(tmp, "refused.ply")
            r = cli("smooth", "builtin:noisy-sphere", "-o", out, "--job-id", "guessing", token_file=wrong)
            assert r.returncode == 1 and "UNAUTHENTICATED" in r.stderr, (r.returncode, r.stderr)
            r = cli("flows", token_file=wrong)
            assert r.returncode == 1 and "bearer token" in r.stderr, (r.returncode, r.stderr)
            r = cli("smooth", "builtin:noisy-sphere", "-o", out, "--iterations", "20000", "--job-id", "too-many")
            assert r.returncode == 1 and "INVALID_ARGUMENT" in r.stderr, (r.returncode, r.stderr)
            r = cli("smooth", "builtin:noisy-sphere", "-o", out, "--iterations", "3", "--job-id", "too-big")
            assert r.returncode == 1 and "RESOURCE_EXHAUSTED" in r.stderr, (r.returncode, r.stderr)
            s = parse_metrics(scrape(guarded.metrics_address))
            assert metric_sum(s, "meshsmooth_refusals_total", reason="unauthenticated") == 2, \
                metric_sum(s, "meshsmooth_refusals_total", reason="unauthenticated")
            assert metric_sum(s, "meshsmooth_refusals_total", reason="invalid_request") == 1
            assert metric_sum(s, "meshsmooth_jobs_total", status="RESOURCE_EXHAUSTED") == 1
            time.sleep(0.2)
            entries = [json.loads(line) for line in guarded.stderr_lines()]
            refused = [e for e in entries if e.get("event") == "refused"]
            assert len(refused) == 3, refused
            for e in refused:
                assert e["level"] == "warning" and e["peer"].startswith("ipv4:127.0.0.1:"), e
                assert e["message"] and e["error"], e
            smooth, flows, spec = refused
            assert (smooth["method"], smooth["status"], smooth["reason"]) == \
                ("Smooth", "UNAUTHENTICATED", "unauthenticated"), smooth
            assert (flows["method"], flows["status"], flows["reason"]) == \
                ("ListFlows", "UNAUTHENTICATED", "unauthenticated"), flows
            assert "job_id" not in smooth and "job_id" not in flows, (smooth, flows)  # no spec was read
            assert (spec["status"], spec["reason"], spec["job_id"]) == \
                ("INVALID_ARGUMENT", "invalid_request", "too-many"), spec
            assert "iterations" in spec["error"], spec
            jobs = [e for e in entries if e.get("event") == "job"]
            assert len(jobs) == 1, jobs
            job = jobs[0]
            assert (job["job_id"], job["status"], job["level"]) == ("too-big", "RESOURCE_EXHAUSTED", "warning"), job
            assert "2562 vertices" in job["error"] and "limit of 1000" in job["error"], job
            assert type(job["iterations_asked"]) is int and job["iterations_asked"] == 3, job
        check("refused calls (a wrong token on Smooth and ListFlows, a bad spec) and a failed job are logged with "
              "status, reason, peer, job id and error; failed authentication is counted", refused_and_failed_calls)
    finally:
        guarded.stop()

    def text_log_names_refusals():
        with Server(a.server, "--auth-token-file", token, stderr=Server.KEEP) as s:
            r = run([a.cli, "flows", "--server", s.address, "--token-file", wrong, "--retries", "0"])
            assert r.returncode == 1, (r.returncode, r.stderr)
            time.sleep(0.2)
            lines = [l for l in s.stderr_lines() if l.startswith("meshsmoothd refused ")]
            assert len(lines) == 1, s.stderr_lines()
            for word in ("method=ListFlows", "status=UNAUTHENTICATED", "reason=unauthenticated", "peer=ipv4:127.0.0.1:",
                         'error="missing or wrong bearer token'):
                assert word in lines[0], (word, lines[0])
    check("the text log has a 'meshsmoothd refused' line with method, status, reason, peer and error",
          text_log_names_refusals)


if __name__ == "__main__":
    sys.exit(main())
