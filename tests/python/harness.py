"""What the Python tests share: named checks counted into 'N passed, M failed', running a
command, the common command-line flags, scratch directories, meshsmoothd started on a free
loopback port and its job log, and PLY header counts.

The tests in this folder import it directly; tests/scale and tests/deploy put this folder on
sys.path first, relative to their own file. Standard library only: the tests run under Debian's
/usr/bin/python3 as it comes.
"""

import argparse
import os
import queue
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import traceback

# ----------------------------------------------------------------------------------------------
# Checks


class CheckFailed(AssertionError):
    """A condition of a check did not hold (raised by require, which -O does not strip)."""


def require(condition, message):
    if not condition:
        raise CheckFailed(message)


def _why(e):
    """The failure line of an exception: an assertion's message (or, without one, the assert
    statement and where it stands); any other exception with its type."""
    if isinstance(e, AssertionError):
        if str(e):
            return str(e)
        frame = traceback.extract_tb(e.__traceback__)[-1]
        return f"{frame.line} ({os.path.basename(frame.filename)}:{frame.lineno})"
    return f"{type(e).__name__}: {e}"


class Checks:
    """Runs named checks and counts them: one that raises fails alone, the others still run.
    Prints 'ok: NAME' or 'FAIL: NAME: WHY' per check (flushed, so the server's log lines stay in
    order with them) and, from summary(), 'N passed, M failed'."""

    def __init__(self):
        self.passed = 0
        self.failed = 0

    def ok(self, name):
        self.passed += 1
        print(f"ok: {name}", flush=True)

    def fail(self, name, why):
        self.failed += 1
        print(f"FAIL: {name}: {why}", flush=True)

    def check(self, name, fn, *args, **kwargs):
        """Runs fn(*args, **kwargs) as the check NAME; returns its value, or None when it failed.
        An exception other than an assertion also prints its traceback on stderr."""
        try:
            value = fn(*args, **kwargs)
        except Exception as e:  # noqa: BLE001 - one failure must not hide the others
            self.fail(name, _why(e))
            if not isinstance(e, AssertionError):
                traceback.print_exc(file=sys.stderr)
            return None
        self.ok(name)
        return value

    def summary(self):
        """Prints 'N passed, M failed'; returns the exit status, 1 when anything failed or when
        no check ran at all (as ctest --no-tests=error: a test that checked nothing has not
        passed)."""
        print(f"{self.passed} passed, {self.failed} failed", flush=True)
        if self.passed + self.failed == 0:
            print("FAIL: no check ran", flush=True)
            return 1
        return 1 if self.failed else 0


def run_checks(body, tmp_prefix=None):
    """body(checks), or with tmp_prefix body(checks, tmp) with a new temporary directory, which
    is removed when every check passed and kept (and named) otherwise. An exception out of body
    is the failed check "test harness". Prints the summary line; returns the exit status."""
    checks = Checks()
    tmp = fresh_dir(prefix=tmp_prefix) if tmp_prefix else None
    try:
        if tmp is None:
            body(checks)
        else:
            body(checks, tmp)
    except Exception as e:  # noqa: BLE001 - a bug in the harness is a failure too
        checks.fail("test harness", _why(e))
        traceback.print_exc(file=sys.stderr)
    status = checks.summary()
    if tmp is not None:
        if status:
            print(f"files kept in {tmp}", flush=True)
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    return status


def shared_file(shared, *parts):
    """The path of shared/data/PARTS under the --shared folder, or None when it is absent (the
    checks on it are left out, and a line says so). Under CI=true an absent file raises
    CheckFailed instead: CI has the folder, and a check left out there passes without doing its
    work."""
    path = os.path.join(shared or "", "data", *parts)
    if shared and os.path.isfile(path):
        return path
    if os.environ.get("CI") == "true":
        raise CheckFailed(f"shared data absent under CI=true: {path} (--shared {shared!r})")
    print(f"skip: {path} absent; the checks that read it are left out", flush=True)
    return None


# ----------------------------------------------------------------------------------------------
# Commands, flags, directories


def run(cmd, timeout=120, **kw):
    """cmd run to its end (at most timeout seconds), its output captured as text."""
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, **kw)


def interrupt_long_job(cmd, out):
    """cmd (a long smooth writing `out`) sent SIGINT 1.5 s in: it must exit 130 within 5 s,
    say it was interrupted and write no file. Returns its stderr."""
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(1.5)
    p.send_signal(signal.SIGINT)
    t0 = time.time()
    _, err = p.communicate(timeout=10)
    assert p.returncode == 130, (p.returncode, err)
    assert time.time() - t0 < 5
    assert "interrupted" in err, err
    assert not os.path.exists(out)
    return err


# The flags tests/CMakeLists.txt gives several tests, with the same meaning in each.
FLAGS = {
    "cli": {"help": "the meshsmooth binary"},
    "server": {"help": "the meshsmoothd binary"},
    "shared": {"default": "", "help": "the shared/ folder with data/meshes and data/draco "
                                      "(the checks that read them skip without it)"},
    "proto-root": {"help": "the folder holding meshsmooth/v1/"},
}


def parser(doc, required=(), optional=()):
    """An argument parser described by the test's docstring, with the named FLAGS."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    for name in required:
        ap.add_argument(f"--{name}", required=True, **FLAGS[name])
    for name in optional:
        ap.add_argument(f"--{name}", **FLAGS[name])
    return ap


def fresh_dir(path=None, prefix="meshsmooth-test-"):
    """path emptied (made if missing), or without it a new temporary directory."""
    if not path:
        return tempfile.mkdtemp(prefix=prefix)
    shutil.rmtree(path, ignore_errors=True)
    os.makedirs(path)
    return path


def write_text(path, text):
    """Writes `text` to `path` (created or truncated) and returns `path`."""
    with open(path, "w") as f:
        f.write(text)
    return path


def free_port():
    """A loopback port nothing listens on (bound, then closed)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# ----------------------------------------------------------------------------------------------
# meshsmoothd

READY = re.compile(r"^meshsmoothd listening on (\S+):(\d+)$")
METRICS_READY = re.compile(r"^meshsmoothd metrics on (\S+):(\d+)$")
JOB_LOG = re.compile(r"^meshsmoothd job=(\S+) .* status=(\S+)")


def job_lines(lines):
    """(job id, status) of each of meshsmoothd's per-job log lines among lines."""
    return [m.groups() for m in map(JOB_LOG.match, lines) if m]


class Server:
    """One meshsmoothd listening on 127.0.0.1:0, started and waited for: the constructor returns
    once it printed its ready line, with address ("127.0.0.1:PORT") and port set (and, when it
    was given --metrics-listen, metrics_address; else that is None); the rest of its
    stdout goes on to stderr. Its stderr (the per-job log lines) is inherited with stderr=None,
    kept in memory with stderr=Server.KEEP, or written to the file named by stderr."""

    KEEP = "keep"

    def __init__(self, binary, *flags, stderr=None, env=None, ready_seconds=30.0):
        require(os.path.isfile(binary) and os.access(binary, os.X_OK),
                f"server binary {binary} not found or not executable")
        self.log_path = stderr if stderr not in (None, Server.KEEP) else None
        self.lines = []
        self._log = open(self.log_path, "wb") if self.log_path else None
        self.proc = subprocess.Popen(
            [binary, "--listen", "127.0.0.1:0", *flags], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE if stderr == Server.KEEP else self._log, text=True, bufsize=1, env=env)
        self._readers = []
        self.metrics_address = None
        if stderr == Server.KEEP:
            self._start(self._keep_stderr)
        # A thread drains stdout for the whole run, so a chatty server never blocks on the pipe.
        self._stdout = queue.Queue()
        self._start(self._read_stdout)
        try:
            self.host, self.port = self._wait_ready(ready_seconds)
        except BaseException:
            self.stop()
            raise
        self.address = f"{self.host}:{self.port}"

    def _start(self, target):
        t = threading.Thread(target=target, daemon=True)
        t.start()
        self._readers.append(t)

    def _keep_stderr(self):
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def _read_stdout(self):
        ready = False
        for raw in self.proc.stdout:
            line = raw.rstrip("\r\n")
            if ready:
                print(f"[meshsmoothd stdout] {line}", file=sys.stderr, flush=True)
            else:
                self._stdout.put(line)
                ready = READY.match(line) is not None
        self._stdout.put(None)

    def _wait_ready(self, seconds):
        seen = []
        while True:
            try:
                line = self._stdout.get(timeout=seconds)
            except queue.Empty:
                raise CheckFailed(f"no ready line within {seconds:.0f} s; stdout so far: {seen!r}") from None
            if line is None:
                raise CheckFailed(f"server exited (code {self.proc.wait()}) before its ready line; "
                                  f"stdout: {seen!r}")
            seen.append(line)
            metrics = METRICS_READY.match(line)
            if metrics:
                self.metrics_address = f"{metrics.group(1)}:{metrics.group(2)}"
            m = READY.match(line)
            if m:
                port = int(m.group(2))
                require(0 < port < 65536, f"bad port in {line!r}")
                return m.group(1), port

    def stderr_lines(self):
        """What it wrote on stderr so far, when kept (Server.KEEP or a file)."""
        if self.log_path:
            with open(self.log_path, errors="replace") as f:
                return f.read().splitlines()
        return list(self.lines)

    def job_lines(self):
        """(job id, status) of each job it logged so far."""
        return job_lines(self.stderr_lines())

    def stop(self, timeout=15):
        """SIGTERM, up to timeout seconds for the exit, then SIGKILL. Returns the exit code and
        whether it had to be killed; a second call returns the code again."""
        killed = False
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                killed = True
        for t in self._readers:
            t.join(timeout=5)
        if self._log:
            self._log.close()
        return self.proc.returncode, killed

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()


def parse_metrics(text):
    """Prometheus's text format as {(name, ((label, value), ...)): value}, labels sorted."""
    samples = {}
    for line in text.splitlines():
        if not line or line.startswith("#"):
            continue
        m = re.match(r'^([a-zA-Z_:][a-zA-Z0-9_:]*)(?:\{(.*)\})? (\S+)$', line)
        require(m is not None, f"not a sample line: {line!r}")
        labels = tuple(sorted(re.findall(r'([a-zA-Z_][a-zA-Z0-9_]*)="((?:[^"\\]|\\.)*)"', m.group(2) or "")))
        samples[(m.group(1), labels)] = float(m.group(3))
    return samples


def metric_sum(samples, name, **labels):
    """The sum of the samples named `name` whose labels include `labels`."""
    return sum(v for (n, ls), v in samples.items() if n == name and all((k, str(x)) in ls for k, x in labels.items()))


# ----------------------------------------------------------------------------------------------
# Files


def ply_header(path):
    """(format, {element name: count}) of an ASCII or binary PLY file's header."""
    with open(path, "rb") as f:
        require(f.readline().strip() == b"ply", f"{path} is not a PLY file")
        counts, fmt = {}, None
        while True:
            line = f.readline()
            require(line != b"", f"{path}: no end_header")
            words = line.decode("ascii", "replace").split()
            if not words:
                continue
            if words[0] == "end_header":
                return fmt, counts
            if words[0] == "format":
                fmt = words[1] if len(words) > 1 else None
            elif words[0] == "element" and len(words) >= 3:
                counts[words[1]] = int(words[2])


def ply_counts(path):
    """(vertices, faces) a PLY file's header declares (None for an element it lacks)."""
    _, counts = ply_header(path)
    return counts.get("vertex"), counts.get("face")
