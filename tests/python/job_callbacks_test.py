#!/usr/bin/python3
"""Completion callbacks of kept jobs (JobSpec.callback_url, meshsmoothd --callback-secret-file)
against real meshsmoothd processes and a local HTTP receiver, and the job's id on every log line
of a kept job.

Run (ctest does this):
  /usr/bin/python3 tests/python/job_callbacks_test.py --server build/server/meshsmoothd \\
      --proto-root proto --cli build/client/meshsmooth

Checks: a job that succeeds, one that fails and one cancelled while it runs each get exactly one
POST, with a valid X-Meshsmooth-Signature (HMAC-SHA256 of the body under the secret) and the
job's id, state, summary or error and times; a receiver that answers 500 twice then 200 gets 3
POSTs of the same body, 1 s and 2 s apart (the documented schedule); a URL of another scheme, a
URL without a host, a server without a secret and a Smooth call naming a callback are
INVALID_ARGUMENT at once; the CLI's submit --callback; every log line of the kept jobs names its
job (text and JSON).
Needs python3-grpcio, python3-numpy, protobuf-compiler-grpc and draco (draco_encoder).
"""

import base64
import hashlib
import hmac
import json
import os
import re
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import grpc

from e2e_client_test import generate_stubs
from harness import Server, parser, require, run, run_checks, write_text
from jobs_test import DEADLINE_S, LONG_SPEC, SHORT_SPEC, Client, code_of, make_meshes

SECRET = "test-callback-secret"
# The receiver's wait for a POST: the first attempt goes at once, the third 1 + 2 s later.
POST_WAIT_S = 20.0


class Receiver:
    """An HTTP server on 127.0.0.1:0 that records every POST (path, headers, body, time) and
    answers with the codes of `answers` in turn, then 200."""

    def __init__(self, answers=()):
        self.posts = []
        self.answers = list(answers)
        self.lock = threading.Lock()
        receiver = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self):  # noqa: N802 - http.server's name
                body = self.rfile.read(int(self.headers.get("Content-Length", "0")))
                with receiver.lock:
                    receiver.posts.append((self.path, dict(self.headers), body, time.time()))
                    code = receiver.answers.pop(0) if receiver.answers else 200
                self.send_response(code)
                self.send_header("Content-Length", "0")
                self.end_headers()

            def log_message(self, *args):
                pass

        self.http = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.thread = threading.Thread(target=self.http.serve_forever, daemon=True)
        self.thread.start()
        self.url = f"http://127.0.0.1:{self.http.server_address[1]}"

    def posts_to(self, path):
        with self.lock:
            return [p for p in self.posts if p[0] == path]

    def wait(self, path, count, seconds=POST_WAIT_S):
        t_end = time.time() + seconds
        while len(self.posts_to(path)) < count:
            require(time.time() < t_end, f"{len(self.posts_to(path))} POSTs to {path} after {seconds} s, not {count}")
            time.sleep(0.02)
        return self.posts_to(path)

    def close(self):
        self.http.shutdown()
        self.http.server_close()


def signature_ok(headers, body):
    want = "sha256=" + hmac.new(SECRET.encode(), body, hashlib.sha256).hexdigest()
    return hmac.compare_digest(headers.get("X-Meshsmooth-Signature", ""), want)


def rfc3339(s):
    return re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?Z", s or "") is not None


def check_one_post_per_end(c, receiver, data, small):
    """SUCCEEDED, FAILED and CANCELLED: one signed POST each with the job's fields."""
    pb2 = c.pb2
    ok = c.submit("cb-ok", c.spec(dict(SHORT_SPEC, callback_url=receiver.url + "/ok")), small).job.job_id
    # Fails when it runs: the upload has no attribute of that name.
    bad = c.submit("cb-fail", c.spec(dict(SHORT_SPEC, strength_attribute="nope", callback_url=receiver.url + "/fail")),
                   small).job.job_id
    long_ = c.submit("cb-cancel", c.spec(dict(LONG_SPEC, callback_url=receiver.url + "/cancel")), data).job.job_id
    c.wait_state(long_, ["JOB_STATE_RUNNING"])
    c.stub.CancelJob(pb2.CancelJobRequest(job_id=long_), timeout=DEADLINE_S)
    c.stub.CancelJob(pb2.CancelJobRequest(job_id=long_), timeout=DEADLINE_S)  # a second cancel: no second POST
    want = {"/ok": (ok, "JOB_STATE_SUCCEEDED"), "/fail": (bad, "JOB_STATE_FAILED"),
            "/cancel": (long_, "JOB_STATE_CANCELLED")}
    for path in want:
        receiver.wait(path, 1)
    time.sleep(1.5)  # a duplicate would come within the first retry's delay
    for path, (job_id, state) in want.items():
        posts = receiver.posts_to(path)
        require(len(posts) == 1, f"{path}: {len(posts)} POSTs")
        _, headers, body, _ = posts[0]
        require(signature_ok(headers, body), f"{path}: signature {headers.get('X-Meshsmooth-Signature')!r}")
        require(headers.get("Content-Type") == "application/json", f"{path}: {headers.get('Content-Type')}")
        doc = json.loads(body)
        require(doc["job_id"] == job_id and doc["state"] == state, f"{path}: {doc.get('job_id')} {doc.get('state')}")
        require("spec" not in doc and doc["request_id"] == "cb-" + path[1:], f"{path}: {sorted(doc)}")
        require(rfc3339(doc.get("create_time")) and rfc3339(doc.get("end_time")), f"{path}: times {doc}")
        job = c.get(job_id)
        require(job.state == pb2.JobState.Value(state), f"{path}: the job is {pb2.JobState.Name(job.state)}")
        if state == "JOB_STATE_SUCCEEDED":
            require(rfc3339(doc.get("start_time")), f"start_time {doc.get('start_time')}")
            require(doc["summary"]["job_id"] == job_id and int(doc["summary"]["result_bytes"]) == job.result_bytes,
                    f"summary {doc.get('summary')}")
            require(base64.b64decode(doc["result_sha256"]) == job.result_sha256, "result_sha256")
        if state == "JOB_STATE_FAILED":
            require(doc["error"]["code"] == grpc.StatusCode.INVALID_ARGUMENT.value[0]
                    and "strength_attribute" in doc["error"]["message"], f"error {doc.get('error')}")
    # A tampered body does not verify.
    _, headers, body, _ = receiver.posts_to("/ok")[0]
    require(not signature_ok(headers, body.replace(b"SUCCEEDED", b"SUCCEEDEX")), "a changed body still verifies")
    return [ok, bad, long_]


def check_retries(c, small, receiver):
    """500, 500, 200: three POSTs of one body, the documented 1 s and 2 s apart."""
    job_id = c.submit("cb-retry", c.spec(dict(SHORT_SPEC, callback_url=receiver.url + "/retry")), small).job.job_id
    posts = receiver.wait("/retry", 3)
    time.sleep(2.5)
    posts = receiver.posts_to("/retry")
    require(len(posts) == 3, f"{len(posts)} POSTs")
    require(len({p[2] for p in posts}) == 1 and all(signature_ok(p[1], p[2]) for p in posts), "one signed body")
    gaps = [posts[i + 1][3] - posts[i][3] for i in range(2)]
    require(0.9 <= gaps[0] <= 1.9 and 1.9 <= gaps[1] <= 2.9, f"gaps {gaps} s, documented 1 and 2")
    print(f"retry gaps {gaps[0]:.2f} s, {gaps[1]:.2f} s", flush=True)
    return job_id


def check_refused(c, c_plain, small):
    """Bad URLs, no secret, Smooth: INVALID_ARGUMENT at once, no byte kept."""
    pb2 = c.pb2
    for i, url in enumerate(["ftp://127.0.0.1/x", "file:///etc/passwd", "not a url", "http://", "x" * 3000]):
        code, details = code_of(lambda: c.submit(f"cb-bad-{i}", c.spec(dict(SHORT_SPEC, callback_url=url)), small))
        require(code == grpc.StatusCode.INVALID_ARGUMENT and "callback_url" in details, (url[:20], code, details))
        held = c.stub.QueryUpload(pb2.QueryUploadRequest(request_id=f"cb-bad-{i}"), timeout=DEADLINE_S)
        require(held.bytes_received == 0, f"{url[:20]}: {held.bytes_received} bytes kept")
    spec = c_plain.spec(dict(SHORT_SPEC, callback_url="http://127.0.0.1:9/x"))
    code, details = code_of(lambda: c_plain.submit("cb-nosecret", spec, small))
    require(code == grpc.StatusCode.INVALID_ARGUMENT and "--callback-secret-file" in details, (code, details))
    code, details = code_of(lambda: c.smooth(spec, small))
    require(code == grpc.StatusCode.INVALID_ARGUMENT and "callback_url" in details, (code, details))


def check_cli(a, server, receiver, tmp):
    r = run([a.cli, "submit", "builtin:noisy-sphere", "--flow", "laplacian", "--iterations", "20", "--callback",
             receiver.url + "/cli", "--server", server.address], timeout=60)
    require(r.returncode == 0 and re.fullmatch(r"[0-9a-f]{32}\n", r.stdout), (r.returncode, r.stdout, r.stderr))
    _, headers, body, _ = receiver.wait("/cli", 1)[0]
    doc = json.loads(body)
    require(signature_ok(headers, body) and doc["job_id"] == r.stdout.strip() and doc["state"] == "JOB_STATE_SUCCEEDED",
            doc)
    return r.stdout.strip()


def check_log_names_jobs(lines, job_ids):
    """Every line but the server's own (meshsmoothd: ...) and the Smooth call's refusal begins
    'meshsmoothd job=ID ' with a kept job's id, and each job has its submitted and callback lines."""
    named = {}
    for line in lines:
        if line.startswith("meshsmoothd: ") or line.startswith("meshsmoothd refused method=Smooth "):
            continue
        m = re.match(r"meshsmoothd job=([0-9a-f]{32}) (.*)", line)
        require(m is not None and m.group(1) in job_ids, f"a log line without a kept job's id: {line!r}")
        named.setdefault(m.group(1), []).append(m.group(2))
    for job_id in job_ids:
        events = named.get(job_id, [])
        require(any(e.startswith("submitted") for e in events), f"{job_id}: {events}")
        require(any(e.startswith("callback for ") for e in events), f"{job_id}: no callback line: {events}")
    return sum(len(v) for v in named.values())


def check_json_log(lines, job_id):
    entries = [json.loads(line) for line in lines]
    kept = [e for e in entries if e["event"] in ("job", "job_submitted", "job_cancelled", "job_deleted", "callback")]
    require(all(e.get("job_id") == job_id for e in kept), [e for e in kept if e.get("job_id") != job_id])
    outcomes = [e["outcome"] for e in kept if e["event"] == "callback"]
    require(outcomes == ["retry", "retry", "delivered"], f"callback entries {outcomes}")
    require([e["http_status"] for e in kept if e["event"] == "callback"] == [500, 500, 200], "http_status")
    require({e["event"] for e in kept} == {"job", "job_submitted", "callback"}, {e["event"] for e in kept})


def main():
    ap = parser(__doc__, required=("server", "proto-root"), optional=("cli",))
    a = ap.parse_args()

    def body(checks, tmp):
        pb2, pb2_grpc = checks.check("python stubs generated from the proto", generate_stubs, a.proto_root, tmp)
        small = checks.check("an icosphere as Draco", make_meshes, tmp, 1)[0]
        big = checks.check("a larger icosphere as Draco", make_meshes, tmp, 1, 5)[0]
        secret_file = write_text(os.path.join(tmp, "secret"), SECRET + "\n")
        receiver = Receiver()
        with Server(a.server, "--workers", "1", "--max-iterations", "1000000", "--job-store",
                    os.path.join(tmp, "store"), "--callback-secret-file", secret_file, stderr=Server.KEEP) as s, \
                Server(a.server, "--job-store", os.path.join(tmp, "plain-store")) as plain:
            c, c_plain = Client(pb2, pb2_grpc, s.address), Client(pb2, pb2_grpc, plain.address)
            ids = checks.check("SUCCEEDED, FAILED and CANCELLED: one signed POST each with the job's fields",
                               check_one_post_per_end, c, receiver, big, small) or []
            checks.check("bad URLs, a server without a secret, Smooth: INVALID_ARGUMENT at submit",
                         check_refused, c, c_plain, small)
            if a.cli:
                ids.append(checks.check("the CLI's submit --callback", check_cli, a, s, receiver, tmp))
            c.close()
            c_plain.close()
            s.stop()
            n = checks.check("every log line of a kept job names it", check_log_names_jobs, s.stderr_lines(), ids)
            print(f"{n} log lines of {len(ids)} kept jobs", flush=True)
        failing = Receiver(answers=[500, 500])
        with Server(a.server, "--job-store", os.path.join(tmp, "retry-store"), "--callback-secret-file", secret_file,
                    "--log-format", "json", stderr=Server.KEEP) as s:
            c = Client(pb2, pb2_grpc, s.address)
            job_id = checks.check("500, 500, 200: three POSTs of one body, 1 s and 2 s apart",
                                  check_retries, c, small, failing)
            c.close()
            s.stop()
            checks.check("JSON log: every entry of the kept job has its job_id; retry, retry, delivered",
                         check_json_log, s.stderr_lines(), job_id)
        receiver.close()
        failing.close()

    return run_checks(body, tmp_prefix="meshsmooth-callbacks-")


if __name__ == "__main__":
    raise SystemExit(main())
