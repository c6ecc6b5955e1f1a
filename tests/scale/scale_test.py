#!/usr/bin/python3
"""Many replicas under load, with failures: nginx in front of three meshsmoothd, then the same
three behind the CLI's own round-robin, 300 jobs from 16 concurrent `meshsmooth smooth`
processes while one replica gets SIGKILL and another SIGTERM.

Each phase starts three fresh replicas on loopback (port 0) and checks, from what the clients
and the replicas' logs say:
  - every job id was run by exactly one client process (none lost, none twice);
  - a job that exited 0 wrote exactly the reference result of its input and parameters
    (results are deterministic: the references come from the CLI's in-process server), and
    its summary names its own job id (each client passes --job-id);
  - a job that failed exited 1 or 3 with a gRPC status ("meshsmooth: UNAVAILABLE: ...") and
    left no output, and at most --max-errors jobs failed;
  - each successful job appears with status=OK in exactly one replica's log, and no replica
    logged a job id that was never sent;
  - every replica (each was alive for part of the run) logged some of the successful jobs;
  - the replica that got SIGTERM exited with status 0 within its grace + 1 s (plus --slack).
Exits 1 on any violation, after printing each one and a summary per phase.

Usage (ctest runs it this way, see tests/CMakeLists.txt):
  scale_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd \
      --nginx-conf deploy/nginx/meshsmooth.conf [--modes nginx,direct] [--jobs 300] [--clients 16]
--break lose|duplicate|wrong tampers with one job on purpose (to see the checks fail);
--self-test runs the checks on made-up records only.
Standard library only: runs under Debian's /usr/bin/python3 as it comes.
"""

import concurrent.futures
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import threading
import time

from cluster import Nginx, Replica

# The harness the Python tests share, tests/python/harness.py.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
from harness import fresh_dir, job_lines, parser, run, run_checks  # noqa: E402

# The inputs and parameters the jobs cycle through: small built-in meshes and fixed iteration
# counts, so 300 jobs stay within the time budget whatever the default job costs, and several
# variants, so a job handed another job's result is seen.
VARIANTS = [
    ["builtin:noisy-sphere", "--flow", "laplacian", "--iterations", "8"],
    ["builtin:noisy-torus", "--flow", "taubin", "--iterations", "6"],
    ["builtin:noisy-plane", "--flow", "bilaplacian", "--iterations", "5"],
    ["builtin:noisy-sphere", "--flow", "bilateral_normal", "--iterations", "2"],
    ["builtin:noisy-torus", "--flow", "mcf", "--iterations", "4"],
    ["builtin:noisy-sphere", "--flow", "median", "--iterations", "5"],
]

CLEAR_STATUS = re.compile(r"^meshsmooth: ([A-Z_]+): \S")
RETRY = re.compile(r"^meshsmooth: attempt \d+ failed", re.M)
SUMMARY_ID = re.compile(r"^job (\S+): ", re.M)  # the summary's first line names the job
CODE_NAMES = {"CANCELLED", "UNKNOWN", "INVALID_ARGUMENT", "DEADLINE_EXCEEDED", "NOT_FOUND",
              "ALREADY_EXISTS", "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION",
              "ABORTED", "OUT_OF_RANGE", "UNIMPLEMENTED", "INTERNAL", "UNAVAILABLE", "DATA_LOSS",
              "UNAUTHENTICATED"}


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def run_cli(cli, args, timeout):
    return run([cli, "smooth"] + args, timeout=timeout)


def make_references(cli, workdir):
    """The result of each variant, computed once by the CLI's in-process server."""
    refs = []
    for i, variant in enumerate(VARIANTS):
        out = os.path.join(workdir, f"reference-{i}.ply")
        r = run_cli(cli, variant + ["-o", out, "--quiet"], timeout=120)
        if r.returncode != 0:
            raise RuntimeError(f"reference {variant}: exit {r.returncode}: {r.stderr.strip()}")
        refs.append(sha256(out))
    return refs


def check_phase(job_ids, variant_of, records, out_dir, refs, replicas, max_errors, slack, grace):
    """Every violation of the pass criteria, as sentences; and the phase's counts."""
    bad = []
    counts = {"ok": 0, "errors": {}, "example": {}, "per_replica": {}}
    by_id = {}
    for rec in records:
        by_id.setdefault(rec["id"], []).append(rec)
    for jid in job_ids:
        n = len(by_id.get(jid, []))
        if n == 0:
            bad.append(f"job {jid}: lost (no client ran it)")
        elif n > 1:
            bad.append(f"job {jid}: duplicated ({n} client runs)")
    for jid in by_id:
        if jid not in variant_of:
            bad.append(f"job {jid}: a result for a job never sent")

    ok_ids = set()
    for jid, recs in by_id.items():
        rec = recs[0]
        out = os.path.join(out_dir, f"{jid}.ply")
        if rec["exit"] == 0:
            m = SUMMARY_ID.search(rec["stdout"])
            summary_id = m.group(1) if m else None
            if summary_id != jid:
                bad.append(f"job {jid}: exit 0 but its summary names job {summary_id!r}")
            if not os.path.exists(out):
                bad.append(f"job {jid}: exit 0 but no output file")
            elif jid in variant_of and sha256(out) != refs[variant_of[jid]]:
                bad.append(f"job {jid}: wrong result (differs from the reference of variant {variant_of[jid]})")
            else:
                ok_ids.add(jid)
                counts["ok"] += 1
        else:
            last = [l for l in rec["stderr"].splitlines() if l.startswith("meshsmooth: ")]
            m = CLEAR_STATUS.match(last[-1]) if last else None
            if rec["exit"] not in (1, 3) or not m or m.group(1) not in CODE_NAMES:
                bad.append(f"job {jid}: failed without a clear status (exit {rec['exit']}): "
                           f"{rec['stderr'].strip()[-300:]!r}")
            else:
                counts["errors"][m.group(1)] = counts["errors"].get(m.group(1), 0) + 1
                counts["example"].setdefault(m.group(1), last[-1])
            if os.path.exists(out):
                bad.append(f"job {jid}: failed but left an output file")
    n_errors = sum(counts["errors"].values())
    if n_errors > max_errors:
        bad.append(f"{n_errors} jobs failed; at most {max_errors} may (the jobs in flight when replicas die)")

    expected_files = {f"{jid}.ply" for jid in ok_ids}
    for name in sorted(set(os.listdir(out_dir)) - expected_files):
        if name[:-4] not in by_id or by_id[name[:-4]][0]["exit"] != 0:
            bad.append(f"output {name}: written for a job that did not succeed")

    ok_logged = {}
    for rep in replicas:
        lines = rep.job_lines()
        n_ok = 0
        for jid, status in lines:
            if jid not in variant_of:
                bad.append(f"{rep.name} logged job {jid}, which was never sent")
            elif status == "OK":
                ok_logged.setdefault(jid, []).append(rep.name)
                n_ok += 1
        counts["per_replica"][rep.name] = n_ok
        if n_ok == 0:
            bad.append(f"{rep.name} ({rep.fate}) smoothed no job: the load was not spread")
    for jid in sorted(ok_ids):
        where = ok_logged.get(jid, [])
        if not where:
            bad.append(f"job {jid}: succeeded but no replica logged it")
        elif len(where) > 1:
            bad.append(f"job {jid}: smoothed {len(where)} times ({', '.join(where)})")

    for rep in replicas:
        if rep.fate == "SIGTERM":
            if rep.exit_seconds is None or rep.exit_code != 0:
                bad.append(f"{rep.name}: after SIGTERM exit code {rep.exit_code}, "
                           f"{'not within the wait' if rep.exit_seconds is None else f'{rep.exit_seconds:.2f} s'}")
            elif rep.exit_seconds > grace + 1 + slack:
                bad.append(f"{rep.name}: exited {rep.exit_seconds:.2f} s after SIGTERM, "
                           f"more than the grace {grace} s + 1 s (+ {slack} s slack)")
    return bad, counts


def run_phase(args, mode, workdir, refs):
    phase_dir = os.path.join(workdir, mode)
    out_dir = os.path.join(phase_dir, "out")
    os.makedirs(out_dir)
    server_args = ["--workers", "1", "--threads-per-job", "1", "--grace-seconds", str(args.grace)]
    server_args += args.server_arg
    replicas = [Replica(args.server, f"replica{i}", phase_dir, server_args) for i in range(3)]
    nginx = None
    try:
        if mode == "nginx":
            nginx = Nginx(args.nginx, args.nginx_conf, phase_dir, [r.address for r in replicas])
            target = f"127.0.0.1:{nginx.port}"
        else:
            target = "ipv4:" + ",".join(r.address for r in replicas)

        job_ids = [f"{mode}-{i:04d}" for i in range(args.jobs)]
        variant_of = {jid: i % len(VARIANTS) for i, jid in enumerate(job_ids)}
        records = []
        lock = threading.Lock()

        def one_job(jid):
            out = os.path.join(out_dir, f"{jid}.ply")
            # Not --json: it silences the CLI's "attempt N failed ... retrying" lines, counted here.
            cmd = VARIANTS[variant_of[jid]] + ["-o", out, "--server", target, "--job-id", jid,
                                               "--retries", str(args.retries), "--timeout", str(args.job_timeout)]
            start = time.monotonic()
            try:
                r = run_cli(args.cli, cmd, timeout=args.job_timeout + 30)
                rec = {"id": jid, "exit": r.returncode, "stdout": r.stdout, "stderr": r.stderr}
            except subprocess.TimeoutExpired:
                rec = {"id": jid, "exit": None, "stdout": "", "stderr": "the client outlived its --timeout by 30 s"}
            rec["seconds"] = time.monotonic() - start
            with lock:
                records.append(rec)
            return rec

        kill_at = int(args.jobs * 0.3)
        term_at = int(args.jobs * 0.55)
        start = time.monotonic()
        done = 0
        terminating = None
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.clients) as pool:
            futures = [pool.submit(one_job, jid) for jid in job_ids]
            for _ in concurrent.futures.as_completed(futures):
                done += 1
                if done == kill_at:
                    replicas[0].kill()
                    replicas[0].killed_after = done
                elif done == term_at:
                    # Timed on a thread of its own so the clients keep being counted meanwhile.
                    replicas[1].killed_after = done
                    terminating = threading.Thread(target=replicas[1].terminate, args=(args.grace + 10,))
                    terminating.start()
        wall = time.monotonic() - start
        if terminating:
            terminating.join()

        with open(os.path.join(phase_dir, "clients.jsonl"), "w") as f:  # what each client said, kept on failure
            f.writelines(json.dumps(r) + "\n" for r in sorted(records, key=lambda r: r["id"]))
        if args.break_one:
            tamper(args.break_one, records, out_dir, variant_of)
        bad, counts = check_phase(job_ids, variant_of, records, out_dir, refs, replicas, args.max_errors,
                                  args.slack, args.grace)
        print_summary(mode, args, wall, counts, replicas, nginx, records)
        return bad
    finally:
        if nginx:
            nginx.stop()
        for r in replicas:
            r.stop()


def tamper(how, records, out_dir, variant_of):
    """Breaks one job's record on purpose: the checks must then fail."""
    victim = next(r for r in records if r["exit"] == 0)
    if how == "lose":
        records.remove(victim)
        os.remove(os.path.join(out_dir, f"{victim['id']}.ply"))
    elif how == "duplicate":
        records.append(dict(victim))
    elif how == "wrong":
        other = next(r for r in records if r["exit"] == 0 and variant_of[r["id"]] != variant_of[victim["id"]])
        shutil.copyfile(os.path.join(out_dir, f"{other['id']}.ply"), os.path.join(out_dir, f"{victim['id']}.ply"))
    print(f"--break {how}: tampered with job {victim['id']}")


def print_summary(mode, args, wall, counts, replicas, nginx, records):
    n = len(records)
    errors = ", ".join(f"{k} {v}" for k, v in sorted(counts["errors"].items())) or "none"
    lat = sorted(r["seconds"] for r in records)
    print(f"[{mode}] {n} jobs from {args.clients} clients in {wall:.1f} s ({n / wall:.1f} jobs/s), "
          f"client latency p50 {lat[len(lat) // 2]:.2f} s, p99 {lat[min(len(lat) - 1, int(len(lat) * 0.99))]:.2f} s")
    retries = [len(RETRY.findall(r["stderr"])) for r in records]
    print(f"[{mode}] ok {counts['ok']}, clear errors {sum(counts['errors'].values())} ({errors}); "
          f"client retries {sum(retries)} in {sum(1 for n in retries if n)} jobs")
    for line in counts["example"].values():
        print(f"[{mode}]   e.g. {line}")
    if nginx:
        reqs = nginx.requests()
        failovers = sum(1 for u, _, _ in reqs if "," in u)
        print(f"[{mode}] nginx saw {len(reqs)} requests for {n} jobs and passed {failovers} of them on to "
              f"another replica")
    for rep in replicas:
        fate = rep.fate
        if rep.fate != "alive":
            fate += f" after {rep.killed_after} jobs"
        if rep.exit_seconds is not None:
            fate += f", exited {rep.exit_seconds:.2f} s later (code {rep.exit_code})"
        print(f"[{mode}] {rep.name} {rep.address}: {counts['per_replica'][rep.name]} jobs ({fate})")


def self_test():
    """The checks on made-up records: each kind of violation must be reported."""
    return run_checks(self_checks, tmp_prefix="scale-selftest-")


def self_checks(checks, tmp):
    """One check per kind of violation: check_phase on records, outputs and replica logs made up
    in tmp must name it (and name nothing for a clean run)."""
    out_dir = os.path.join(tmp, "out")
    os.makedirs(out_dir)
    ids = ["a", "b", "c"]
    variant_of = {"a": 0, "b": 1, "c": 0}
    refs = []
    for v in range(2):
        with open(os.path.join(tmp, f"ref{v}"), "wb") as f:
            f.write(f"mesh {v}".encode())
        refs.append(sha256(os.path.join(tmp, f"ref{v}")))

    class FakeReplica:
        def __init__(self, name, lines, fate="alive"):
            self.name, self.fate, self.exit_code, self.exit_seconds = name, fate, 0, 0.5
            self.lines = [f"meshsmoothd job={j} flow=x status={s} decode=0s" for j, s in lines]

        def job_lines(self):
            return job_lines(self.lines)

    def write(jid, v):
        with open(os.path.join(out_dir, f"{jid}.ply"), "wb") as f:
            f.write(f"mesh {v}".encode())

    def ok(jid):
        return {"id": jid, "exit": 0, "stdout": f"job {jid}: laplacian, 8 iterations\n", "stderr": ""}

    def violations(records, logs, max_errors=1):
        reps = [FakeReplica(f"r{i}", l) for i, l in enumerate(logs)]
        return check_phase(ids, variant_of, records, out_dir, refs, reps, max_errors, 0, 1)[0]

    good_logs = [[("a", "OK")], [("b", "OK"), ("c", "UNAVAILABLE")]]
    failed_c = {"id": "c", "exit": 3, "stdout": "", "stderr": "meshsmooth: UNAVAILABLE: replica went away\n"}
    write("a", 0)
    write("b", 1)
    cases = {
        "a clean run": ([ok("a"), ok("b"), failed_c], good_logs, None),
        "a lost job": ([ok("a"), ok("b")], good_logs, "lost"),
        "a job run twice": ([ok("a"), ok("b"), failed_c, ok("a")], good_logs, "duplicated"),
        "a wrong result": ([ok("a"), ok("b"), failed_c], good_logs, "wrong result"),
        "a failure without a status": ([ok("a"), ok("b"), dict(failed_c, stderr="Segmentation fault\n",
                                                                 exit=-11)], good_logs, "clear status"),
        "a summary of another job": ([ok("a"), dict(ok("b"), stdout="job a: laplacian\n"), failed_c], good_logs,
                                     "summary names"),
        "a job smoothed twice": ([ok("a"), ok("b"), failed_c], [[("a", "OK")], [("b", "OK"), ("a", "OK")]],
                                 "smoothed 2 times"),
        "a success no replica logged": ([ok("a"), ok("b"), failed_c], [[("a", "OK")], [("c", "OK")]],
                                        "no replica logged"),
        "an idle replica": ([ok("a"), ok("b"), failed_c], good_logs + [[]], "smoothed no job"),
        "too many failures": ([ok("a"), ok("b"), failed_c], good_logs, "jobs failed"),
    }

    def caught(name, records, logs, expect):
        if name == "a wrong result":
            write("b", 0)
        try:
            bad = violations(records, logs, max_errors=0 if name == "too many failures" else 1)
        finally:
            if name == "a wrong result":
                write("b", 1)
        if expect:
            assert any(expect in b for b in bad), f"no violation naming {expect!r}: {bad}"
        else:
            assert not bad, bad

    for name, (records, logs, expect) in cases.items():
        checks.check(f"{name}: {f'reported ({expect!r})' if expect else 'no violation'}",
                     caught, name, records, logs, expect)


def main():
    p = parser(__doc__, optional=("cli", "server"))
    p.add_argument("--nginx", default=shutil.which("nginx") or "/usr/sbin/nginx")
    p.add_argument("--nginx-conf", help="the deployment file deploy/nginx/meshsmooth.conf")
    p.add_argument("--modes", default="nginx,direct", help="nginx (through the proxy), direct (client round-robin)")
    p.add_argument("--jobs", type=int, default=300)
    p.add_argument("--clients", type=int, default=16)
    p.add_argument("--retries", type=int, default=4, help="the CLI's --retries")
    p.add_argument("--grace", type=float, default=2.0, help="the replicas' --grace-seconds")
    p.add_argument("--slack", type=float, default=1.0, help="seconds beyond grace + 1 s a loaded machine may take")
    p.add_argument("--max-errors", type=int, default=None, help="jobs allowed to fail; default 2 x --clients")
    p.add_argument("--job-timeout", type=float, default=60.0)
    p.add_argument("--server-arg", action="append", default=[], help="one more meshsmoothd argument (repeat)")
    p.add_argument("--workdir", help="where the replicas' logs and the results go (default: a temporary "
                   "directory); removed after a run without violations unless --keep")
    p.add_argument("--keep", action="store_true", help="keep --workdir after a run without violations")
    p.add_argument("--break", dest="break_one", choices=["lose", "duplicate", "wrong"],
                   help="tamper with one job after the run: the test must fail")
    p.add_argument("--self-test", action="store_true", help="check the checks on made-up records")
    args = p.parse_args()
    if args.self_test:
        return self_test()
    if not (args.cli and args.server):
        p.error("--cli and --server are required")
    if args.max_errors is None:
        args.max_errors = 2 * args.clients
    modes = args.modes.split(",")
    if "nginx" in modes:
        if not args.nginx_conf:
            p.error("--nginx-conf is required for the nginx mode")
        if not os.access(args.nginx, os.X_OK):
            print(f"scale test: no nginx at {args.nginx} (scripts/setup.sh installs Debian's)", file=sys.stderr)
            return 1

    workdir = fresh_dir(args.workdir, prefix="meshsmooth-scale-")
    start = time.monotonic()
    refs = make_references(args.cli, workdir)
    violations = []
    for mode in modes:
        violations += [f"[{mode}] {v}" for v in run_phase(args, mode, workdir, refs)]
    print(f"scale test: {len(violations)} violations, {time.monotonic() - start:.1f} s in all")
    for v in violations:
        print("VIOLATION " + v)
    if violations:
        print(f"scale test: files kept in {workdir}")
        return 1
    if not args.keep:
        shutil.rmtree(workdir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
