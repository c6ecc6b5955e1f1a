"""Processes for tests and benchmarks of many replicas: meshsmoothd replicas on loopback and
nginx in front of them, configured from deploy/nginx/meshsmooth.conf. Standard library only.
Used by tests/scale/scale_test.py and bench/replicas.py."""

import os
import re
import signal
import socket
import subprocess
import sys
import time

# The harness the Python tests share, tests/python/harness.py.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))
from harness import CheckFailed, Server, free_port  # noqa: E402


class Replica(Server):
    """One meshsmoothd on 127.0.0.1:0; its stderr (the per-job log lines) goes to a file."""

    def __init__(self, binary, name, workdir, extra_args):
        self.name = name
        self.fate = "alive"
        self.exit_code = None
        self.exit_seconds = None
        log_path = os.path.join(workdir, f"{name}.log")
        try:
            super().__init__(binary, *extra_args, stderr=log_path)
        except CheckFailed as e:
            raise RuntimeError(f"{name} did not start: {e} (log: {log_path})") from None

    def kill(self):
        self.fate = "SIGKILL"
        self.proc.send_signal(signal.SIGKILL)
        self.exit_code = self.proc.wait()

    def terminate(self, wait_seconds):
        """SIGTERM, then waits (up to wait_seconds) for the exit and times it."""
        self.fate = "SIGTERM"
        start = time.monotonic()
        self.proc.send_signal(signal.SIGTERM)
        try:
            self.exit_code = self.proc.wait(timeout=wait_seconds)
            self.exit_seconds = time.monotonic() - start
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.exit_code = self.proc.wait()

    def stop(self, timeout=10):
        return super().stop(timeout)


NGINX_MAIN = """\
daemon off;
worker_processes 1;
pid {dir}/nginx.pid;
error_log {dir}/error.log notice;
events {{ worker_connections 1024; }}
http {{
    log_format scale '$upstream_addr $status $upstream_trailer_grpc_status $request_time';
    access_log {dir}/access.log scale;
    client_body_temp_path {dir}/tmp/body;
    proxy_temp_path {dir}/tmp/proxy;
    fastcgi_temp_path {dir}/tmp/fastcgi;
    uwsgi_temp_path {dir}/tmp/uwsgi;
    scgi_temp_path {dir}/tmp/scgi;
{site}
}}
"""


def nginx_site(template, port, upstreams):
    """The deployment file with its `listen` line and the upstream's `server` lines replaced."""
    listen = re.compile(r"^(\s*)listen\s+[^;]*;", re.M)
    server = re.compile(r"^(\s*)server\s+[^\s{;]+[^;{]*;[ \t]*\n", re.M)
    if len(listen.findall(template)) != 1 or not server.search(template):
        raise RuntimeError("the nginx template needs one `listen` line and an upstream with `server` lines")
    site = listen.sub(lambda m: f"{m.group(1)}listen 127.0.0.1:{port} http2;", template)
    first = server.search(site)
    lines = "".join(f"{first.group(1)}server {u};\n" for u in upstreams)
    site = site[:first.start()] + lines + server.sub("", site[first.start():])
    return "\n".join("    " + l if l else l for l in site.splitlines())


class Nginx:
    """nginx unprivileged in the foreground, its prefix, logs and temp files under `workdir`."""

    def __init__(self, binary, template_path, workdir, upstreams):
        self.dir = os.path.join(workdir, "nginx")
        os.makedirs(os.path.join(self.dir, "tmp"), exist_ok=True)
        # Workers of an nginx started by root run as nobody: they must reach the temp paths.
        os.chmod(workdir, 0o755)
        os.chmod(self.dir, 0o755)
        with open(template_path) as f:
            template = f.read()
        for attempt in range(5):  # the port is free when picked; another process may take it first
            self.port = free_port()
            conf = os.path.join(self.dir, "nginx.conf")
            with open(conf, "w") as f:
                f.write(NGINX_MAIN.format(dir=self.dir, site=nginx_site(template, self.port, upstreams)))
            self.proc = subprocess.Popen([binary, "-p", self.dir, "-c", conf, "-e", f"{self.dir}/error.log"],
                                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            if self._wait_ready():
                return
            self.stop()
        raise RuntimeError(f"nginx did not start: see {self.dir}/error.log")

    def _wait_ready(self):
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                return False
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.5):
                    return True
            except OSError:
                time.sleep(0.05)
        return False

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGQUIT)  # graceful: finish the requests, then exit
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def requests(self):
        """(upstream addresses tried, HTTP status, grpc-status) of each request nginx logged."""
        rows = []
        path = os.path.join(self.dir, "access.log")
        if os.path.exists(path):
            with open(path) as f:
                for line in f:
                    parts = line.rsplit(" ", 3)
                    if len(parts) == 4:
                        rows.append((parts[0], parts[1], parts[2]))
        return rows


