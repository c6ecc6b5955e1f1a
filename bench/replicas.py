#!/usr/bin/python3
"""Throughput and latency of one and three meshsmoothd replicas, directly (the client's own
round-robin) and through nginx (deploy/nginx/meshsmooth.conf), measured by meshsmooth_load.
Prints Markdown: one row per setup, then nginx's cost per job against a direct call.

  bench/replicas.py [--build build] [--clients 8] [--jobs 300] [--seq-jobs 200] [--rounds 3]
                    [--job "--input builtin:noisy-sphere --flow bilaplacian --iterations 40"] ...

Each setup runs --seq-jobs jobs from one client (latency with nothing queued: nginx's cost per
job is the difference of the mean latencies) and --jobs jobs from --clients clients (throughput),
--rounds times, direct and through nginx alternating; each figure is the median of the rounds.
Replicas run with their defaults (workers and threads per job = hardware threads), so three
replicas share the cores one replica already uses. --job may be repeated: one table per job.
Long CPU use: run it alone (docs/performance.md says under which lock).
"""

import argparse
import os
import re
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "scale"))
from cluster import Nginx, Replica  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULT = re.compile(r"(\w+)=([-\d.]+)")


def load(binary, target, clients, jobs, job_args):
    cmd = [binary, "--target", target, "--clients", str(clients), "--jobs", str(jobs)] + job_args
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {r.returncode}: {r.stdout}{r.stderr}")
    return {k: float(v) for k, v in RESULT.findall(r.stdout)}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    p.add_argument("--nginx", default=shutil.which("nginx") or "/usr/sbin/nginx")
    p.add_argument("--nginx-conf", default=os.path.join(ROOT, "deploy", "nginx", "meshsmooth.conf"))
    p.add_argument("--clients", type=int, default=8)
    p.add_argument("--jobs", type=int, default=300)
    p.add_argument("--seq-jobs", type=int, default=200)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--job", action="append", help="meshsmooth_load job options (default: 40 iterations of bilaplacian "
                   "on builtin:noisy-sphere)")
    args = p.parse_args()
    server = os.path.join(args.build, "server", "meshsmoothd")
    loader = os.path.join(args.build, "bench", "meshsmooth_load")
    jobs = args.job or ["--input builtin:noisy-sphere --flow bilaplacian --iterations 40"]

    for job in jobs:
        job_args = shlex.split(job)
        print(f"\nJob: `{job}`; {args.clients} clients x {args.jobs} jobs, 1 client x {args.seq_jobs} jobs; "
              f"medians of {args.rounds} rounds, direct and nginx alternating.\n")
        print("| replicas | path | clients | jobs/s | p50 ms | p99 ms | mean ms |")
        print("|---|---|---|---|---|---|---|")
        overhead = {}
        for n in (1, 3):
            workdir = tempfile.mkdtemp(prefix="meshsmooth-replicas-")
            replicas = [Replica(server, f"replica{i}", workdir, ["--quiet"]) for i in range(n)]
            nginx = None
            try:
                nginx = Nginx(args.nginx, args.nginx_conf, workdir, [r.address for r in replicas])
                targets = {"direct": "ipv4:" + ",".join(r.address for r in replicas),
                           "nginx": f"127.0.0.1:{nginx.port}"}
                for clients, count in ((1, args.seq_jobs), (args.clients, args.jobs)):
                    runs = {path: [] for path in targets}
                    for _ in range(args.rounds):
                        for path, target in targets.items():
                            runs[path].append(load(loader, target, clients, count, job_args))
                    for path, rs in runs.items():
                        m = {k: statistics.median(r[k] for r in rs) for k in rs[0]}
                        print(f"| {n} | {path} | {clients} | {m['jobs_per_second']:.1f} | {m['p50_ms']:.2f} "
                              f"| {m['p99_ms']:.2f} | {m['mean_ms']:.2f} |", flush=True)
                    if clients == 1:
                        overhead[n] = [x["mean_ms"] - d["mean_ms"] for d, x in zip(runs["direct"], runs["nginx"])]
            except RuntimeError:
                if nginx:  # why the proxy failed, before its directory goes
                    with open(os.path.join(nginx.dir, "error.log")) as f:
                        sys.stderr.write("".join(f.readlines()[-20:]))
                raise
            finally:
                if nginx:
                    nginx.stop()
                for r in replicas:
                    r.stop()
                shutil.rmtree(workdir, ignore_errors=True)
        print()
        for n, diffs in overhead.items():
            print(f"nginx's cost per job, {n} replica{'s' if n > 1 else ''}, one client (mean latency through nginx "
                  f"minus direct, per round): median {statistics.median(diffs):+.2f} ms, rounds "
                  + ", ".join(f"{d:+.2f}" for d in diffs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
