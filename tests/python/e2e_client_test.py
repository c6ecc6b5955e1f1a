#!/usr/bin/python3
"""End-to-end test of meshsmoothd through its gRPC API, from an independent Python client.

Run (ctest does this):
  /usr/bin/python3 tests/python/e2e_client_test.py --server build/server/meshsmoothd \
      --cli build/client/meshsmooth --proto-root proto [--shared ../shared]

Needs only Debian packages: python3-grpcio, python3-protobuf, python3-numpy, protobuf-compiler,
protobuf-compiler-grpc (grpc_python_plugin) and draco (draco_encoder, draco_decoder).
Stubs are generated from the .proto at test time, so this client is written against the
public contract, not against the C++ code. The upload with a per-vertex strength
(JobSpec.strength_attribute) needs a GENERIC Draco attribute named by its metadata, which
draco_encoder does not write: the meshsmooth CLI makes those bytes (make_strength_upload), and
this client sends them itself. Prints one "ok: ..." / "FAIL: ..." line per check
and closes with "N passed, M failed"; exits 1 when anything failed.
"""

import importlib
import os
import re
import sys

import numpy as np

from harness import Server, parser, ply_counts, require, run, run_checks, shared_file

PROTO_FILE = "meshsmooth/v1/smoothing.proto"
GRPC_PYTHON_PLUGIN = "/usr/bin/grpc_python_plugin"
# Every flow of smoothing.proto's contract (README's list): ListFlows names exactly these, and
# each runs end to end.
EXPECTED_FLOWS = {"laplacian", "taubin", "bilaplacian", "mcf", "mcf_tangential", "median", "bilateral_normal",
                  "guided_normal"}
SMOOTH_DEADLINE_S = 60.0
ERROR_DEADLINE_S = 30.0
# Well below the contract's 1 MiB limit. The lossless sequential test mesh is ~15 KB, so 64 KiB
# would send it in one piece: 4 KiB makes it several chunks and exercises reassembly.
CHUNK_BYTES = 4 * 1024
ICOSPHERE_VERTICES = 642
ICOSPHERE_FACES = 1280
# The strength upload's vertex properties (GENERIC attributes named by their metadata): the
# strength, and a property with one value outside [0, 1].
STRENGTH_PROPERTY = "strength"
OUT_OF_RANGE_PROPERTY = "over"


# ----------------------------------------------------------------------------------------------
# Stubs


def generate_stubs(proto_root, out_dir):
    """Generates the Python stubs of smoothing.proto into out_dir; returns (pb2, pb2_grpc)."""
    proto_root = os.path.abspath(proto_root)
    require(os.path.isfile(os.path.join(proto_root, PROTO_FILE)),
            f"{PROTO_FILE} not found under {proto_root}")
    cmd = ["protoc", "-I", proto_root, f"--python_out={out_dir}", f"--grpc_out={out_dir}",
           f"--plugin=protoc-gen-grpc={GRPC_PYTHON_PLUGIN}", PROTO_FILE]
    r = run(cmd)
    require(r.returncode == 0, f"protoc failed ({r.returncode}): {r.stderr.strip()}")
    # Regular packages, so that an unrelated 'meshsmooth' elsewhere on sys.path cannot shadow them.
    for pkg in ("meshsmooth", os.path.join("meshsmooth", "v1")):
        init = os.path.join(out_dir, pkg, "__init__.py")
        if not os.path.exists(init):
            open(init, "w").close()
    sys.path.insert(0, out_dir)
    importlib.invalidate_caches()
    pb2 = importlib.import_module("meshsmooth.v1.smoothing_pb2")
    pb2_grpc = importlib.import_module("meshsmooth.v1.smoothing_pb2_grpc")
    require(hasattr(pb2_grpc, "MeshSmootherStub"), "generated stubs have no MeshSmootherStub")
    return pb2, pb2_grpc


# ----------------------------------------------------------------------------------------------
# Test mesh


def icosphere(subdivisions):
    """Unit icosphere, outward-oriented faces; 10 * 4^s + 2 vertices, 20 * 4^s faces."""
    t = (1.0 + 5.0 ** 0.5) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
             (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
             (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [np.array(v, dtype=np.float64) / np.linalg.norm(v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
             (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
             (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
             (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        cache = {}

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]

        new_faces = []
        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            new_faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new_faces
    return np.array(verts), np.array(faces, dtype=np.int64)


def signed_volume(verts, faces):
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def write_ascii_ply(path, verts, faces):
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\n")
        f.write(f"element vertex {len(verts)}\n")
        f.write("property float x\nproperty float y\nproperty float z\n")
        f.write(f"element face {len(faces)}\n")
        f.write("property list uchar int vertex_indices\nend_header\n")
        for x, y, z in verts:  # float32 values, 9 significant digits: exact round trip
            f.write(f"{x:.9g} {y:.9g} {z:.9g}\n")
        for i, j, k in faces:
            f.write(f"3 {i} {j} {k}\n")


def make_test_mesh(work_dir):
    """Noisy icosphere as ASCII PLY, then Draco via draco_encoder. Returns the .drc bytes."""
    verts, faces = icosphere(3)
    require(len(verts) == ICOSPHERE_VERTICES and len(faces) == ICOSPHERE_FACES,
            f"icosphere has {len(verts)} vertices / {len(faces)} faces")
    rng = np.random.default_rng(1)
    verts = (verts + rng.uniform(-0.02, 0.02, size=verts.shape)).astype(np.float32)
    require(signed_volume(verts.astype(np.float64), faces) > 0, "icosphere is inside out")
    ply = os.path.join(work_dir, "mesh.ply")
    drc = os.path.join(work_dir, "mesh.drc")
    write_ascii_ply(ply, verts, faces)
    r = run(["draco_encoder", "-i", ply, "-o", drc, "-qp", "0", "-cl", "0"])
    require(r.returncode == 0 and os.path.isfile(drc),
            f"draco_encoder failed ({r.returncode}): {r.stdout.strip()} {r.stderr.strip()}")
    with open(drc, "rb") as f:
        data = f.read()
    require(len(data) > 2 * CHUNK_BYTES, f"mesh.drc is only {len(data)} bytes: too few chunks")
    return data


def write_strength_ply(path, verts, faces, strength, over):
    """ASCII PLY with float x, y, z and the float properties STRENGTH_PROPERTY, OUT_OF_RANGE_PROPERTY."""
    with open(path, "w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {len(verts)}\n")
        f.write("property float x\nproperty float y\nproperty float z\n")
        f.write(f"property float {STRENGTH_PROPERTY}\nproperty float {OUT_OF_RANGE_PROPERTY}\n")
        f.write(f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        for (x, y, z), s, o in zip(verts, strength, over):
            f.write(f"{x:.9g} {y:.9g} {z:.9g} {s:.9g} {o:.9g}\n")
        for i, j, k in faces:
            f.write(f"3 {i} {j} {k}\n")


def ply_positions(path):
    """The float32 (n, 3) positions of a binary little-endian PLY whose vertices are float x, y, z
    alone (what draco_decoder writes for a mesh without normals, colours or texture coordinates)."""
    with open(path, "rb") as f:
        raw = f.read()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    header = raw[:end].decode("ascii").splitlines()
    require("format binary_little_endian 1.0" in header, f"{path}: not binary little-endian")
    start = next(i for i, line in enumerate(header) if line.startswith("element vertex "))
    n = int(header[start].split()[2])
    props = header[start + 1:start + 4]
    require(props == ["property float x", "property float y", "property float z"]
            and not header[start + 4].startswith("property"), f"{path}: vertex properties {header[start + 1:]}")
    return np.frombuffer(raw, dtype="<f4", count=3 * n, offset=end).reshape(n, 3)


def decode_positions(work_dir, name, data):
    """data (Draco bytes) decoded by draco_decoder: the float32 positions, point i of the mesh."""
    drc, ply = os.path.join(work_dir, f"{name}.drc"), os.path.join(work_dir, f"{name}.ply")
    with open(drc, "wb") as f:
        f.write(data)
    r = run(["draco_decoder", "-i", drc, "-o", ply])
    require(r.returncode == 0, f"draco_decoder failed ({r.returncode}): {r.stdout.strip()} {r.stderr.strip()}")
    return ply_positions(ply)


def make_strength_upload(work_dir, cli):
    """The noisy icosphere with a per-vertex strength, as Draco bytes holding it in a GENERIC
    attribute named by its metadata. Returns (bytes, float32 positions, strength, over).

    Strength 0 below z = -0.3, 1 above z = 0.3, linear between; OUT_OF_RANGE_PROPERTY is 0.25
    but at vertex 7 (1.5). Debian's draco_encoder writes no named GENERIC attributes, so the
    meshsmooth CLI converts the PLY: its encoder writes each PLY vertex property as one, and
    --region around a point far from the mesh gives every vertex strength 0 in its own job, so
    the .drc it writes holds the input's positions as they were. Both are checked here rather
    than assumed: draco_decoder reads the same float32 positions back, in order, and the bytes
    hold each property's float32 values in vertex order (a lossless sequential encoding stores a
    float attribute's values as they are)."""
    verts, faces = icosphere(3)
    rng = np.random.default_rng(1)
    verts = (verts + rng.uniform(-0.02, 0.02, size=verts.shape)).astype(np.float32)
    z = verts[:, 2].astype(np.float64)
    strength = np.clip((z + 0.3) / 0.6, 0.0, 1.0).astype(np.float32)
    over = np.full(len(verts), 0.25, dtype=np.float32)
    over[7] = 1.5
    ply = os.path.join(work_dir, "strength.ply")
    drc = os.path.join(work_dir, "strength.drc")
    write_strength_ply(ply, verts, faces, strength, over)
    r = run([cli, "smooth", ply, "--flow", "laplacian", "--iterations", "1", "--region", "sphere:100,100,100,1",
             "--quiet", "-o", drc])
    require(r.returncode == 0, f"meshsmooth smooth failed ({r.returncode}): {r.stderr.strip()}")
    with open(drc, "rb") as f:
        data = f.read()
    require(np.array_equal(decode_positions(work_dir, "strength_upload", data), verts),
            "the CLI's .drc does not hold the PLY's positions bit for bit, in order")
    for name, values in ((STRENGTH_PROPERTY, strength), (OUT_OF_RANGE_PROPERTY, over)):
        require(values.astype("<f4").tobytes() in data, f"the CLI's .drc does not hold the values of {name!r}")
    require((strength == 0).sum() > 100 and (strength == 1).sum() > 100,
            f"{(strength == 0).sum()} vertices of strength 0, {(strength == 1).sum()} of strength 1")
    return data, verts, strength, over


def decode_counts(work_dir, name, data):
    """Writes data to NAME.drc, decodes it with draco_decoder to NAME.ply; returns (v, f)."""
    drc = os.path.join(work_dir, f"{name}.drc")
    ply = os.path.join(work_dir, f"{name}.ply")
    with open(drc, "wb") as f:
        f.write(data)
    r = run(["draco_decoder", "-i", drc, "-o", ply])
    require(r.returncode == 0 and os.path.isfile(ply),
            f"draco_decoder failed ({r.returncode}): {r.stdout.strip()} {r.stderr.strip()}")
    return ply_counts(ply)


# ----------------------------------------------------------------------------------------------
# Checks


def chunked(data, size):
    for i in range(0, len(data), size):
        yield data[i:i + size]


def check_list_flows(stub, pb2):
    reply = stub.ListFlows(pb2.ListFlowsRequest(), timeout=10)
    names = [f.name for f in reply.flows]
    require(len(names) == len(set(names)), f"a flow named twice: {names}")
    missing, extra = EXPECTED_FLOWS - set(names), set(names) - EXPECTED_FLOWS
    require(not missing and not extra, f"missing flows {sorted(missing)}, unexpected {sorted(extra)}; got {names}")
    for flow in reply.flows:
        described = [p.name for p in flow.parameters if p.description.strip()]
        require(described, f"flow {flow.name!r} has no parameter with a description "
                           f"({len(flow.parameters)} parameters)")
    return names


def run_smooth(stub, pb2, spec, data):
    """Streams spec + data in CHUNK_BYTES chunks; returns (responses, code, details, error)."""
    def requests():
        yield pb2.SmoothRequest(spec=spec)
        for chunk in chunked(data, CHUNK_BYTES):
            yield pb2.SmoothRequest(mesh_chunk=chunk)

    call = stub.Smooth(requests(), timeout=SMOOTH_DEADLINE_S)
    responses, error = [], None
    try:
        for response in call:
            responses.append(response)
    except Exception as e:  # grpc.RpcError; the call object still reports code/details
        error = e
    return responses, call.code(), call.details(), error


def check_smooth_status(result, grpc):
    _, code, details, _ = result
    require(code == grpc.StatusCode.OK, f"status {code} {details!r}")


def check_smooth_order(responses):
    kinds = [r.WhichOneof("kind") for r in responses]
    letters = "".join({"accepted": "A", "progress": "P", "result_chunk": "R",
                       "summary": "S"}.get(k, "?") for k in kinds)
    require(responses, "no responses")
    require(re.fullmatch(r"AP*R+S", letters),
            f"order is not accepted, progress*, result_chunk+, summary: {letters!r}")
    return letters


def check_accepted(responses):
    require(responses and responses[0].WhichOneof("kind") == "accepted",
            "first response is not accepted")
    acc = responses[0].accepted
    require(acc.job_id, "empty job_id")
    rep = acc.input
    require(rep.vertices == ICOSPHERE_VERTICES, f"input.vertices {rep.vertices}")
    require(rep.faces == ICOSPHERE_FACES, f"input.faces {rep.faces}")
    require(rep.closed, "input.closed is false")


# ProgressPhase values of meshsmooth.v1 (smoothing.proto).
PROGRESS_PHASE_SMOOTHING = 1
PROGRESS_PHASE_WRITING = 4


def check_progress(responses):
    progress = [r.progress for r in responses if r.WhichOneof("kind") == "progress"]
    smoothing = [p for p in progress if p.phase == PROGRESS_PHASE_SMOOTHING]
    require(smoothing, f"no progress of the smoothing phase: {[(p.phase, p.iteration, p.total) for p in progress]}")
    for p in smoothing:
        require(p.total == 10, f"progress.total {p.total}, expected 10")
        require(p.iteration <= p.total, f"progress.iteration {p.iteration} > total {p.total}")
    require(progress[-1].phase == PROGRESS_PHASE_WRITING,
            f"the last progress is phase {progress[-1].phase}, not writing")
    return len(progress)


def result_bytes_of(responses):
    return b"".join(r.result_chunk for r in responses if r.WhichOneof("kind") == "result_chunk")


def check_summary(responses):
    require(responses and responses[-1].WhichOneof("kind") == "summary",
            "last response is not summary")
    s = responses[-1].summary
    nsummaries = sum(1 for r in responses if r.WhichOneof("kind") == "summary")
    require(nsummaries == 1, f"{nsummaries} summaries")
    require(s.parameters.flow == "median", f"parameters.flow {s.parameters.flow!r}")
    require(s.parameters.iterations_run == 10,
            f"parameters.iterations_run {s.parameters.iterations_run}")
    require(s.after.signed_volume > 0, f"after.signed_volume {s.after.signed_volume}")
    total = len(result_bytes_of(responses))
    require(total > 0, "no result bytes")
    require(s.result_bytes == total, f"summary.result_bytes {s.result_bytes} != {total} received")


def check_result_decodes(work_dir, responses):
    data = result_bytes_of(responses)
    require(data, "no result bytes")
    v, f = decode_counts(work_dir, "result", data)
    require(v == ICOSPHERE_VERTICES and f == ICOSPHERE_FACES,
            f"result.ply has {v} vertices / {f} faces")


def check_flow_runs(stub, pb2, grpc, work_dir, flow, mesh):
    """One Smooth call of `flow`, 3 iterations: status OK, the summary's flow and count, and a
    result draco_decoder reads back with the input's counts."""
    responses, code, details, _ = run_smooth(stub, pb2, pb2.JobSpec(flow=flow, iterations=3), mesh)
    require(code == grpc.StatusCode.OK, f"status {code} {details!r}")
    require(responses and responses[-1].WhichOneof("kind") == "summary", "last response is not summary")
    s = responses[-1].summary
    require(s.parameters.flow == flow, f"parameters.flow {s.parameters.flow!r}")
    require(s.parameters.iterations_run == 3, f"parameters.iterations_run {s.parameters.iterations_run}")
    v, f = decode_counts(work_dir, f"result_{flow}", result_bytes_of(responses))
    require((v, f) == (ICOSPHERE_VERTICES, ICOSPHERE_FACES), f"result has {v} vertices / {f} faces")


def expect_error(stub, grpc, messages, code_name, words):
    """Sends messages; the call must end with status code_name and a message naming words."""
    call = stub.Smooth(iter(messages), timeout=ERROR_DEADLINE_S)
    try:
        for _ in call:
            pass
    except grpc.RpcError:
        pass
    code, details = call.code(), call.details() or ""
    expected = getattr(grpc.StatusCode, code_name)
    require(code == expected, f"status {code} {details!r}, expected {code_name}")
    for word in words:
        require(word.lower() in details.lower(), f"message {details!r} does not name {word!r}")
    return details


def check_strength_result(stub, pb2, grpc, work_dir, upload):
    """laplacian, 10 iterations, with strength_attribute: status OK; returns the result's
    float32 positions and its bytes."""
    data = upload[0]
    spec = pb2.JobSpec(flow="laplacian", iterations=10, strength_attribute=STRENGTH_PROPERTY)
    responses, code, details, _ = run_smooth(stub, pb2, spec, data)
    require(code == grpc.StatusCode.OK, f"status {code} {details!r}")
    s = responses[-1].summary
    require(s.parameters.flow == "laplacian" and s.parameters.iterations_run == 10,
            f"ran {s.parameters.flow!r} for {s.parameters.iterations_run} iterations")
    result = result_bytes_of(responses)
    return decode_positions(work_dir, "strength_result", result), result


def check_strength_zero_kept(upload, after):
    _, before, strength, _ = upload
    held = strength == 0
    require(after.shape == before.shape, f"{len(after)} points back for {len(before)}")
    changed = np.flatnonzero(held & np.any(after != before, axis=1))
    require(changed.size == 0, f"{changed.size} of {held.sum()} vertices of strength 0 moved, e.g. {changed[:5]}")
    return int(held.sum())


def check_strength_one_moves(upload, after):
    _, before, strength, _ = upload
    full = strength == 1
    moved = np.linalg.norm(after[full].astype(np.float64) - before[full], axis=1)
    require(np.all(moved > 0), f"{(moved == 0).sum()} of {full.sum()} vertices of strength 1 did not move")
    require(moved.mean() > 1e-3, f"vertices of strength 1 moved {moved.mean():.2e} on average")
    return int(full.sum())


def check_strength_control(stub, pb2, grpc, work_dir, upload):
    """The same job without strength_attribute moves the vertices of strength 0: what keeps
    them is the strength, not the flow."""
    data, before, strength, _ = upload
    responses, code, details, _ = run_smooth(stub, pb2, pb2.JobSpec(flow="laplacian", iterations=10), data)
    require(code == grpc.StatusCode.OK, f"status {code} {details!r}")
    after = decode_positions(work_dir, "strength_control", result_bytes_of(responses))
    held = strength == 0
    still = np.all(after[held] == before[held], axis=1)
    require(not still.any(), f"{still.sum()} of {held.sum()} vertices of strength 0 did not move without it")


def strength_messages(pb2, data, attribute):
    return [pb2.SmoothRequest(spec=pb2.JobSpec(flow="laplacian", iterations=10, strength_attribute=attribute))] + [
        pb2.SmoothRequest(mesh_chunk=c) for c in chunked(data, CHUNK_BYTES)]


def run_strength_checks(checks, stub, pb2, grpc, work_dir, upload):
    out = checks.check(f"strength: laplacian, 10 iterations, strength_attribute {STRENGTH_PROPERTY!r} ends OK",
                       check_strength_result, stub, pb2, grpc, work_dir, upload)
    if out is not None:
        after, result = out
        checks.check("strength: every vertex of strength 0 comes back bit for bit",
                     check_strength_zero_kept, upload, after)
        checks.check("strength: every vertex of strength 1 moves", check_strength_one_moves, upload, after)
        checks.check("strength: the attribute comes back unchanged (its float32 values in vertex order)",
                     lambda: require(upload[2].astype("<f4").tobytes() in result,
                                     "the result does not hold the strength's values"))
    checks.check("strength: without strength_attribute the vertices of strength 0 move (control)",
                 check_strength_control, stub, pb2, grpc, work_dir, upload)
    checks.check("error: strength_attribute naming no attribute of the upload -> INVALID_ARGUMENT naming it",
                 expect_error, stub, grpc, strength_messages(pb2, upload[0], "no_such_attribute"),
                 "INVALID_ARGUMENT", ["strength_attribute", "no_such_attribute"])
    checks.check("error: strength_attribute with a value of 1.5 -> INVALID_ARGUMENT naming it",
                 expect_error, stub, grpc, strength_messages(pb2, upload[0], OUT_OF_RANGE_PROPERTY),
                 "INVALID_ARGUMENT", ["strength_attribute", OUT_OF_RANGE_PROPERTY])


# ----------------------------------------------------------------------------------------------


def main():
    args = parser(__doc__, required=("server", "cli", "proto-root"), optional=("shared",)).parse_args()
    return run_checks(lambda checks, tmp: run_all(args, checks, tmp), tmp_prefix="meshsmooth-e2e-")


def check_health(channel):
    """grpc.health.v1.Health/Check with raw bytes: an empty request; SERVING is field 1 = 1."""
    check = channel.unary_unary("/grpc.health.v1.Health/Check",
                                request_serializer=lambda b: b, response_deserializer=lambda b: b)
    reply = check(b"", timeout=10)
    if reply != b"\x08\x01":
        raise AssertionError(f"health reply {reply!r}, expected SERVING (b'\\x08\\x01')")


def check_reflection(channel):
    """grpc.reflection.v1alpha list_services (field 7, empty string) names our service."""
    info = channel.stream_stream("/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
                                 request_serializer=lambda b: b, response_deserializer=lambda b: b)
    replies = list(info(iter([b"\x3a\x00"]), timeout=10))
    if not any(b"meshsmooth.v1.MeshSmoother" in r for r in replies):
        raise AssertionError(f"reflection did not list meshsmooth.v1.MeshSmoother: {replies!r}")


def run_all(args, checks, tmp):
    stub_dir = os.path.join(tmp, "stubs")
    work_dir = os.path.join(tmp, "work")
    os.makedirs(stub_dir)
    os.makedirs(work_dir)

    stubs = checks.check("python stubs generated from the proto", generate_stubs,
                         args.proto_root, stub_dir)
    if stubs is None:
        return
    pb2, pb2_grpc = stubs
    import grpc  # after the stubs, so a missing python3-grpcio shows up as that check failing

    mesh = checks.check("test mesh: noisy icosphere (642 v, 1280 f) encoded by draco_encoder",
                        make_test_mesh, work_dir)
    if mesh is not None:
        checks.check("test mesh decodes back to 642 v / 1280 f with draco_decoder",
                     lambda: require(decode_counts(work_dir, "input", mesh)
                                     == (ICOSPHERE_VERTICES, ICOSPHERE_FACES),
                                     "draco_decoder counts differ"))

    strength_upload = checks.check(
        "strength upload: the CLI's .drc of a PLY with float properties holds its positions bit for bit "
        "and each property as an attribute", make_strength_upload, work_dir, args.cli)

    server = checks.check("server starts and prints its ready line",
                          Server, args.server, "--workers", "2")
    if server is None:
        return
    channel = None
    try:
        channel = grpc.insecure_channel(server.address)
        ready = checks.check("gRPC channel ready within 10 s",
                             lambda: grpc.channel_ready_future(channel).result(timeout=10) or True)
        if ready is None:
            return
        stub = pb2_grpc.MeshSmootherStub(channel)

        checks.check("health service answers SERVING", check_health, channel)
        checks.check("server reflection lists meshsmooth.v1.MeshSmoother", check_reflection, channel)
        checks.check(f"ListFlows names exactly the {len(EXPECTED_FLOWS)} flows, each with a described parameter",
                     check_list_flows, stub, pb2)

        if mesh is not None:
            for flow in sorted(EXPECTED_FLOWS):
                checks.check(f"{flow}: 3 iterations end OK, the summary names it, the result decodes to "
                             "642 v / 1280 f", check_flow_runs, stub, pb2, grpc, work_dir, flow, mesh)
            spec = pb2.JobSpec(flow="median", iterations=10)
            result = checks.check("Smooth call made (median, 10 iterations, 4 KiB chunks)",
                                  run_smooth, stub, pb2, spec, mesh)
            if result is not None:
                responses = result[0]
                checks.check("Smooth ends with status OK", check_smooth_status, result, grpc)
                checks.check("Smooth response order accepted, progress*, result_chunk+, "
                             "summary", check_smooth_order, responses)
                checks.check("accepted: job_id, 642 vertices, 1280 faces, closed",
                             check_accepted, responses)
                checks.check("progress: iteration <= total == 10", check_progress, responses)
                checks.check("summary: median, 10 iterations run, positive volume, "
                             "result_bytes matches", check_summary, responses)
                checks.check("result decodes with draco_decoder to 642 v / 1280 f",
                             check_result_decodes, work_dir, responses)

        if strength_upload is not None:
            run_strength_checks(checks, stub, pb2, grpc, work_dir, strength_upload)

        spec_median = pb2.JobSpec(flow="median", iterations=10)
        checks.check("error: mesh_chunk first -> INVALID_ARGUMENT naming the spec",
                     expect_error, stub, grpc,
                     [pb2.SmoothRequest(mesh_chunk=mesh or b"\0" * 16)],
                     "INVALID_ARGUMENT", ["spec"])
        checks.check("error: unknown flow -> INVALID_ARGUMENT naming it",
                     expect_error, stub, grpc,
                     [pb2.SmoothRequest(spec=pb2.JobSpec(flow="nope", iterations=10))]
                     + [pb2.SmoothRequest(mesh_chunk=c) for c in chunked(mesh or b"", CHUNK_BYTES)],
                     "INVALID_ARGUMENT", ["nope"])
        checks.check("error: garbage bytes -> INVALID_ARGUMENT naming draco",
                     expect_error, stub, grpc,
                     [pb2.SmoothRequest(spec=spec_median),
                      pb2.SmoothRequest(mesh_chunk=b"not draco at all")],
                     "INVALID_ARGUMENT", ["draco"])
        checks.check("error: two specs -> INVALID_ARGUMENT naming the spec",
                     expect_error, stub, grpc,
                     [pb2.SmoothRequest(spec=spec_median), pb2.SmoothRequest(spec=spec_median)],
                     "INVALID_ARGUMENT", ["spec"])
        cube_pc = shared_file(args.shared, "draco", "cube_pc.drc")
        if cube_pc:
            with open(cube_pc, "rb") as f:
                pc = f.read()
            checks.check("error: Draco point cloud -> INVALID_ARGUMENT naming it",
                         expect_error, stub, grpc,
                         [pb2.SmoothRequest(spec=spec_median)]
                         + [pb2.SmoothRequest(mesh_chunk=c) for c in chunked(pc, CHUNK_BYTES)],
                         "INVALID_ARGUMENT", ["point cloud"])
    finally:
        if channel is not None:
            channel.close()
        code, killed = server.stop(timeout=10)
        checks.check("server exits cleanly on SIGTERM within 10 s",
                     lambda: require(not killed and code == 0,
                                     "killed after 10 s" if killed else f"exit code {code}"))


if __name__ == "__main__":
    sys.exit(main())
