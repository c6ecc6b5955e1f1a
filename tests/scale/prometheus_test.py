#!/usr/bin/python3
"""Debian's Prometheus server scraping two meshsmoothd replicas, as in a cluster: it starts with a
configuration of its own in a temporary folder (scrape interval 1 s, both replicas' metrics
ports as static targets), the CLI sends a known number of jobs, alternately to each replica,
and Prometheus's HTTP query API must answer sum(meshsmooth_jobs_total) = the jobs sent, and,
once one replica is killed (SIGKILL), up == 0 for that target while the other stays up.

Run by ctest: prometheus_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd
    [--prometheus /usr/bin/prometheus] [--jobs 8]
Prints one line per check and ends with 'N passed, M failed'.
"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import urllib.parse
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
from harness import Server, free_port, parser, require, run, run_checks  # noqa: E402

CONFIG = """\
global:
  scrape_interval: 1s
  scrape_timeout: 1s
  evaluation_interval: 1s
scrape_configs:
  - job_name: meshsmoothd
    static_configs:
      - targets: [{targets}]
"""


class Prometheus:
    """prometheus on a free loopback port, its configuration and database under `workdir`."""

    def __init__(self, binary, workdir, targets):
        self.dir = os.path.join(workdir, "prometheus")
        os.makedirs(self.dir, exist_ok=True)
        conf = os.path.join(self.dir, "prometheus.yml")
        with open(conf, "w") as f:
            f.write(CONFIG.format(targets=", ".join(f'"{t}"' for t in targets)))
        self.log = open(os.path.join(self.dir, "prometheus.log"), "wb")
        for _ in range(5):  # the port is free when picked; another process may take it first
            self.port = free_port()
            self.proc = subprocess.Popen(
                [binary, f"--config.file={conf}", f"--storage.tsdb.path={self.dir}/data",
                 f"--web.listen-address=127.0.0.1:{self.port}", "--log.level=warn"],
                stdin=subprocess.DEVNULL, stdout=self.log, stderr=self.log)
            if self._ready():
                return
            self.stop()
        raise RuntimeError(f"prometheus did not start: see {self.dir}/prometheus.log")

    def _ready(self):
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and self.proc.poll() is None:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{self.port}/-/ready", timeout=1) as r:
                    if r.status == 200:
                        return True
            except OSError:
                pass
            time.sleep(0.2)
        return False

    def query(self, promql):
        """The instant vector of `promql` as [(labels, value)]."""
        url = f"http://127.0.0.1:{self.port}/api/v1/query?" + urllib.parse.urlencode({"query": promql})
        with urllib.request.urlopen(url, timeout=5) as r:
            body = json.load(r)
        require(body.get("status") == "success", f"query {promql!r}: {body}")
        return [(s["metric"], float(s["value"][1])) for s in body["data"]["result"]]

    def wait_for(self, promql, want, seconds):
        """Polls `promql` until want(result) holds; returns (result, seconds waited)."""
        start = time.monotonic()
        result = None
        while time.monotonic() - start < seconds:
            result = self.query(promql)
            if want(result):
                return result, time.monotonic() - start
            time.sleep(0.5)
        raise AssertionError(f"{promql!r} after {seconds} s: {result}")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def main():
    ap = parser(__doc__, required=("cli", "server"))
    ap.add_argument("--prometheus", default=shutil.which("prometheus") or "/usr/bin/prometheus")
    ap.add_argument("--jobs", type=int, default=8)
    a = ap.parse_args()
    return run_checks(lambda checks, tmp: prometheus_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-prom-")


def prometheus_checks(a, check, tmp):
    require(os.access(a.prometheus, os.X_OK), f"{a.prometheus} not found (scripts/setup.sh installs prometheus)")
    replicas = [Server(a.server, "--metrics-listen", "127.0.0.1:0", "--workers", "1", "--quiet") for _ in range(2)]
    prom = None
    try:
        targets = [r.metrics_address for r in replicas]
        require(all(targets), f"a replica without a metrics line: {targets}")
        prom = Prometheus(a.prometheus, tmp, targets)

        def both_up():
            result, waited = prom.wait_for("up", lambda r: len(r) == 2 and all(v == 1 for _, v in r), 30)
            print(f"  both targets up after {waited:.1f} s", flush=True)
        check("Prometheus scrapes both replicas: up == 1 for each", both_up)

        def jobs_counted():
            for i in range(a.jobs):
                r = run([a.cli, "smooth", "builtin:noisy-sphere", "-o", os.path.join(tmp, f"out{i}.ply"),
                         "--iterations", "2", "--server", replicas[i % 2].address, "--quiet"])
                assert r.returncode == 0, r.stderr
            result, waited = prom.wait_for("sum(meshsmooth_jobs_total)",
                                           lambda r: len(r) == 1 and r[0][1] == a.jobs, 30)
            per = prom.query("sum by (instance) (meshsmooth_jobs_total)")
            print(f"  sum(meshsmooth_jobs_total) = {result[0][1]:g} after {waited:.1f} s; per replica: "
                  f"{sorted((m['instance'], v) for m, v in per)}", flush=True)
            assert sorted(v for _, v in per) == [a.jobs // 2, a.jobs - a.jobs // 2], f"per replica: {per}"
            vertices = prom.query("sum(meshsmooth_vertices_processed_total)")
            assert vertices and vertices[0][1] == 2562 * a.jobs, vertices
        check(f"{a.jobs} jobs over both replicas: Prometheus's sum(meshsmooth_jobs_total) is {a.jobs}", jobs_counted)

        def killed_is_down():
            victim, survivor = replicas[0], replicas[1]
            victim.proc.send_signal(signal.SIGKILL)
            victim.proc.wait(timeout=10)
            result, waited = prom.wait_for(f'up{{instance="{victim.metrics_address}"}}',
                                           lambda r: len(r) == 1 and r[0][1] == 0, 30)
            print(f"  up == 0 for the killed replica {waited:.1f} s after SIGKILL", flush=True)
            alive = prom.query(f'up{{instance="{survivor.metrics_address}"}}')
            assert alive and alive[0][1] == 1, alive
        check("a replica killed with SIGKILL shows up == 0, the other stays up == 1", killed_is_down)
    finally:
        if prom:
            prom.stop()
        for r in replicas:
            r.stop()


if __name__ == "__main__":
    sys.exit(main())
