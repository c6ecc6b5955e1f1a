#!/usr/bin/python3
"""The meshsmooth CLI as a user runs it: help, smoothing with the embedded server and through
meshsmoothd, JSON output, flows, info, exit codes, and Ctrl-C.

Run by ctest: cli_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd [--shared DIR]
Prints one line per check and ends with 'N passed, M failed'.
"""
import json
import os
import re
import struct
import sys
import zlib

from harness import Server, interrupt_long_job, parser, ply_counts, run, run_checks, shared_file, write_text


def flow_names(cli, *server):
    """The flow names, in order, of `meshsmooth flows --json` (the ListFlows response as JSON),
    from the in-process server or, given "--server", ADDRESS, from that one."""
    r = run([cli, "flows", "--json", *server])
    assert r.returncode == 0, (r.returncode, r.stderr)
    return [f["name"] for f in json.loads(r.stdout)["flows"]]


def read_ply_colors(path):
    """(vertex count, face count, [(r, g, b)] per vertex) of a PLY whose vertices are x y z (float
    or double) followed by red green blue uchar (binary little endian or ASCII)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise AssertionError(f"{path}: not a PLY file")
    header = data[:end].decode().splitlines()
    body = data[end + len(b"end_header\n"):]
    fmt, vertices, faces, props, element = None, None, None, [], None
    for line in header:
        parts = line.split()
        if parts[:1] == ["format"]:
            fmt = parts[1]
        elif parts[:1] == ["element"]:
            element = parts[1]
            if element == "vertex":
                vertices = int(parts[2])
            elif element == "face":
                faces = int(parts[2])
        elif parts[:1] == ["property"] and element == "vertex":
            props.append((parts[1], parts[2]))
    # Positions in float, or in double when float could not hold the input's.
    kind = props[0][0] if props else "float"
    want = [(kind, "x"), (kind, "y"), (kind, "z"), ("uchar", "red"), ("uchar", "green"), ("uchar", "blue")]
    assert kind in ("float", "double") and props == want, f"{path}: vertex properties {props}, want {want}"
    assert vertices is not None and faces is not None, header
    if fmt == "binary_little_endian":
        rec = struct.Struct("<3d3B" if kind == "double" else "<3f3B")
        assert len(body) >= vertices * rec.size + faces * 13, f"{path}: truncated body"
        colors = [rec.unpack_from(body, i * rec.size)[3:] for i in range(vertices)]
    elif fmt == "ascii":
        lines = body.decode().splitlines()
        colors = [tuple(int(x) for x in lines[i].split()[3:6]) for i in range(vertices)]
    else:
        raise AssertionError(f"{path}: unexpected PLY format {fmt}")
    return vertices, faces, colors


# FeatureColors() in core/features/ridges.h: ridges black, ravines white, the rest light grey.
GREY, BLACK, WHITE = (200, 200, 200), (0, 0, 0), (255, 255, 255)


def label_colour_counts(colors):
    """(black, white) counts; fails when a vertex is neither black, white nor grey."""
    others = [c for c in colors if c not in (GREY, BLACK, WHITE)]
    assert not others, f"{len(others)} vertices neither grey, black nor white, e.g. {others[:3]}"
    return colors.count(BLACK), colors.count(WHITE)


def read_png(path):
    """(width, height, rows of RGB tuples) of an 8-bit RGB, non-interlaced PNG."""
    with open(path, "rb") as f:
        data = f.read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: no PNG signature: {data[:8]!r}"
    assert data[12:16] == b"IHDR", f"{path}: the first chunk is {data[12:16]!r}, not IHDR"
    width, height = struct.unpack(">II", data[16:24])
    depth, colour_type, _, _, interlace = data[24:29]
    assert (depth, colour_type, interlace) == (8, 2, 0), (depth, colour_type, interlace)
    idat, pos = b"", 8
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind = data[pos + 4:pos + 8]
        chunk = data[pos + 8:pos + 8 + length]
        assert zlib.crc32(kind + chunk) == struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])[0], kind
        if kind == b"IDAT":
            idat += chunk
        pos += 12 + length
        if kind == b"IEND":
            break
    raw = zlib.decompress(idat)
    stride = 3 * width
    assert len(raw) == height * (stride + 1), (len(raw), width, height)
    rows, prev = [], bytearray(stride)
    for y in range(height):
        ftype, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - 3] if i >= 3 else 0
            b = prev[i]
            c = prev[i - 3] if i >= 3 else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 255
            elif ftype == 2:
                line[i] = (line[i] + b) & 255
            elif ftype == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
            else:
                assert ftype == 0, f"bad PNG filter type {ftype}"
        rows.append([tuple(line[x * 3:x * 3 + 3]) for x in range(width)])
        prev = line
    return width, height, rows


def main():
    ap = parser(__doc__, required=("cli", "server"), optional=("shared",))
    ap.add_argument("--sanitized", action="store_true", help="ASan build: no huge-page re-exec")
    a = ap.parse_args()
    return run_checks(lambda checks, tmp: cli_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-cli-")


def cli_checks(a, check, tmp):
    """Every check, in order; the files they write go to tmp."""
    cli = a.cli

    def help_lists_defaults():
        r = run([cli, "smooth", "--help"])
        assert r.returncode == 0, r.returncode
        for word in ("--flow", "bilaplacian", "--iterations", "auto", "--server", "--quantization-bits", "--json"):
            assert word in r.stdout, f"'{word}' missing from smooth --help"
        r = run([cli, "--help"])
        assert r.returncode == 0 and "Exit codes" in r.stdout and "builtin:" in r.stdout
    check("--help explains options with defaults, exit codes and built-in inputs", help_lists_defaults)

    out_ply = os.path.join(tmp, "sphere.ply")

    def embedded_smooth():
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out_ply, "--iterations", "5"])
        assert r.returncode == 0, r.stderr
        assert ply_counts(out_ply) == (2562, 5120), ply_counts(out_ply)
        assert "edge length CV" in r.stdout, r.stdout
    check("smooth with the embedded server writes the whole mesh", embedded_smooth)

    def json_summary():
        r = run([cli, "smooth", "builtin:noisy-torus", "-o", os.path.join(tmp, "t.obj"), "--flow", "taubin", "--json"])
        assert r.returncode == 0, r.stderr
        s = json.loads(r.stdout)
        assert s["parameters"]["flow"] == "taubin", s["parameters"]
        assert s["after"]["edge_length_cv"] > 0
    check("--json prints the summary as JSON", json_summary)

    def flow_choices_are_the_flows():
        # --flow's choices and help come from the flow table: every flow ListFlows names is
        # offered, accepted and runs; a name it does not list is refused.
        names = flow_names(cli)
        r = run([cli, "smooth", "--help"])
        assert r.returncode == 0, r.returncode
        # "auto" (the default: the server chooses) comes first.
        assert "{auto," + ",".join(names) + "}=auto" in r.stdout, r.stdout
        assert "auto | " + " | ".join(names) in r.stdout, r.stdout
        for name in names:
            out = os.path.join(tmp, f"flow_{name}.ply")
            r = run([cli, "smooth", "builtin:sphere", "-o", out, "--flow", name, "--iterations", "1", "--json"])
            assert r.returncode == 0, (name, r.returncode, r.stderr)
            assert json.loads(r.stdout)["parameters"]["flow"] == name, (name, r.stdout)
        r = run([cli, "smooth", "builtin:sphere", "-o", os.path.join(tmp, "flow_x.ply"), "--flow", names[0] + "x"])
        assert r.returncode == 2 and "--flow" in r.stderr, (r.returncode, r.stderr)
    check("--flow offers and accepts exactly the flows ListFlows names", flow_choices_are_the_flows)

    def bad_usage():
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out_ply, "--flow", "nope"])
        assert r.returncode == 2, r.returncode
        r = run([cli, "smooth", "/nonexistent.obj", "-o", out_ply])
        assert r.returncode == 1 and "cannot open" in r.stderr, (r.returncode, r.stderr)
    check("bad command line exits 2, bad input exits 1 with a message", bad_usage)

    def usage_errors_exit_2():
        # Each is a mistake in the command line, caught before any work: exit 2, naming the option.
        out = os.path.join(tmp, "usage.ply")
        cases = [
            (["builtin:noisy-sphere", "-o", os.path.join(tmp, "x.xyz")], ["x.xyz", ".ply"]),
            (["builtin:noisy-sphere", "-o", out, "--step", "5"], ["step", "5"]),
            (["builtin:nope", "-o", out], ["builtin:nope", "noisy-sphere"]),
            (["builtin:noisy-sphere", "-o", out, "--token-file", os.path.join(tmp, "absent.token")],
             ["--token-file", "absent.token"]),
            (["builtin:noisy-sphere", "-o", out, "--timeout", "0"], ["--timeout"]),
            (["builtin:noisy-sphere", "-o", out, "--timeout", "-1"], ["--timeout"]),
            (["builtin:noisy-sphere", "-o", out, "--timeout", "nan"], ["--timeout"]),
            # Edgebreaker's order of the result's points would be written over the input's faces.
            (["builtin:noisy-sphere", "-o", out, "--edgebreaker"], ["--edgebreaker", ".drc"]),
        ]
        for args, words in cases:
            r = run([cli, "smooth", *args])
            assert r.returncode == 2, (args, r.returncode, r.stderr)
            for w in words:
                assert w in r.stderr, (args, w, r.stderr)
            assert not os.path.exists(out), args
        for sub in (["info", "builtin:nope"], ["ridges", "builtin:nope", "-o", os.path.join(tmp, "n.ply")],
                    ["render", "builtin:nope", "-o", os.path.join(tmp, "n.png")]):
            r = run([cli, *sub])
            assert r.returncode == 2 and "builtin:nope" in r.stderr, (sub, r.returncode, r.stderr)
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out, "--timeout", "0.5", "--iterations", "1"])
        assert r.returncode == 0, (r.returncode, r.stderr)
    check("an unknown output format, a step out of range, an unknown builtin, a missing token file, --timeout 0 "
          "or -1, --edgebreaker for a .ply: exit 2 naming it", usage_errors_exit_2)

    def readme_promises_what_the_cli_offers():
        readme = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "README.md")
        with open(readme) as f:
            text = " ".join(f.read().split())
        r = run([cli, "smooth", "--help"])
        assert r.returncode == 0, r.returncode
        # Vertices are held by a per-vertex strength: the CLI's options for it are the README's.
        for option in ("--weight", "--fixed", "--region", "--outside", "--falloff"):
            assert option in r.stdout, f"smooth --help does not list {option}"
            assert f"`{option}" in text, f"README does not explain {option}"
        assert "FlowParams::strength" in text, "README does not say where the library's strength is"
    check("README explains every per-vertex strength option smooth --help lists, and the library's field",
          readme_promises_what_the_cli_offers)

    def fixed_file_keeps_its_vertices():
        noisy = os.path.join(tmp, "fixed-in.obj")
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", noisy, "--flow", "laplacian", "--iterations", "1", "-q"])
        assert r.returncode == 0, r.stderr
        fixed = list(range(0, 2562, 7))
        listing = os.path.join(tmp, "fixed.txt")
        with open(listing, "w") as f:
            f.write("# every seventh vertex\n" + "\n".join(map(str, fixed)) + "\n")
        out = os.path.join(tmp, "fixed-out.obj")
        r = run([cli, "smooth", noisy, "-o", out, "--fixed", listing, "-q"])
        assert r.returncode == 0, r.stderr

        def vertex_lines(path):
            with open(path) as f:
                return [line for line in f if line.startswith("v ")]
        before, after = vertex_lines(noisy), vertex_lines(out)
        assert len(before) == len(after) == 2562, (len(before), len(after))
        held = [i for i in fixed if before[i] != after[i]]
        assert not held, f"fixed vertices moved: {held[:5]}"
        assert sum(b != a for b, a in zip(before, after)) > 1000, "the other vertices hardly moved"
        with open(listing, "a") as f:
            f.write("2562\n")
        r = run([cli, "smooth", noisy, "-o", out, "--fixed", listing, "-q"])
        assert r.returncode == 1 and "--fixed" in r.stderr and "out of range" in r.stderr, (r.returncode, r.stderr)
        r = run([cli, "smooth", noisy, "-o", out, "--region", "box:1,2,3"])
        assert r.returncode == 2 and "--region box:1,2,3" in r.stderr, (r.returncode, r.stderr)
    check("smooth --fixed keeps the listed vertices' lines bit for bit; an index out of range exits 1, a malformed "
          "--region 2, each naming the flag", fixed_file_keeps_its_vertices)

    def unreachable():
        r = run([cli, "smooth", "builtin:sphere", "-o", out_ply, "--server", "127.0.0.1:1", "--timeout", "5"])
        assert r.returncode == 3, (r.returncode, r.stderr)
    check("an unreachable server exits 3", unreachable)

    ridges_ply = os.path.join(tmp, "ridges.ply")

    def ridges_command():
        r = run([cli, "ridges", "builtin:noisy-sphere", "-o", ridges_ply])
        assert r.returncode == 0, (r.returncode, r.stderr)
        m = re.search(r"(\d+) ridge and (\d+) ravine vertices of (\d+) classified \((\d+) vertices; "
                      r"\|curvature\| threshold (\S+)\); wrote (\S+)", r.stdout)
        assert m, r.stdout
        ridges, ravines, classified, vertices = (int(m.group(i)) for i in range(1, 5))
        # No --threshold: auto, a share of the mesh's own curvature scale (above 0).
        assert float(m.group(5)) > 0, m.group(5)
        assert m.group(6) == ridges_ply, m.group(6)
        n, faces, colors = read_ply_colors(ridges_ply)
        assert (n, faces) == (2562, 5120), (n, faces)
        assert vertices == n, (vertices, n)
        assert 0 < classified <= n, classified
        assert ridges > 0 and ravines > 0, (ridges, ravines)  # a noisy sphere has both
        assert ridges + ravines <= classified, (ridges, ravines, classified)
        assert label_colour_counts(colors) == (ridges, ravines), (label_colour_counts(colors), ridges, ravines)
        # A threshold above every curvature leaves no feature: all grey.
        r = run([cli, "ridges", "builtin:noisy-sphere", "-o", os.path.join(tmp, "none.ply"), "--threshold", "1e9"])
        assert r.returncode == 0, r.stderr
        assert r.stdout.startswith("0 ridge and 0 ravine vertices"), r.stdout
        assert set(read_ply_colors(os.path.join(tmp, "none.ply"))[2]) == {GREY}
    check("ridges writes black ridges and white ravines as counted, the rest grey", ridges_command)

    def ridges_bad_usage():
        obj = os.path.join(tmp, "ridges.obj")
        r = run([cli, "ridges", "builtin:noisy-sphere", "-o", obj])
        assert r.returncode == 2, (r.returncode, r.stderr)
        assert ".ply" in r.stderr, r.stderr
        assert not os.path.exists(obj)
        for bad in ["-1", "abc", "nan"]:
            r = run([cli, "ridges", "builtin:noisy-sphere", "-o", os.path.join(tmp, "neg.ply"), "--threshold", bad])
            assert r.returncode == 2 and "--threshold" in r.stderr, (bad, r.returncode, r.stderr)
    check("ridges to a non-PLY file or with a negative or unreadable threshold exits 2", ridges_bad_usage)

    def smooth_with_ridges():
        out = os.path.join(tmp, "smoothed_ridges.ply")
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out, "--ridges", "--iterations", "10"])
        assert r.returncode == 0, (r.returncode, r.stderr)
        m = re.search(r"^features: (\d+) ridge and (\d+) ravine vertices of (\d+) classified", r.stdout, re.M)
        assert m, r.stdout
        ridges, ravines, classified = (int(m.group(i)) for i in range(1, 4))
        n, faces, colors = read_ply_colors(out)
        assert (n, faces) == (2562, 5120), (n, faces)
        assert 0 < classified <= n and ridges + ravines <= classified, (ridges, ravines, classified)
        assert ridges > 0, ridges
        assert label_colour_counts(colors) == (ridges, ravines), (label_colour_counts(colors), ridges, ravines)
        # --json carries the same counts.
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out, "--ridges", "--iterations", "10", "--json"])
        assert r.returncode == 0, r.stderr
        f = json.loads(r.stdout)["features"]
        assert (int(f.get("ridge_vertices", 0)), int(f.get("ravine_vertices", 0)),
                int(f["classified_vertices"])) == (ridges, ravines, classified), f
        # Without --ridges: no features line.
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", os.path.join(tmp, "plain.ply"), "--iterations", "10"])
        assert r.returncode == 0 and "features:" not in r.stdout, r.stdout
    check("smooth --ridges prints the counts and colours the PLY to match", smooth_with_ridges)

    def smooth_keeps_ply_colours():
        # The coloured PLY of the ridges check goes in; its colours come out unchanged.
        out = os.path.join(tmp, "recoloured.ply")
        r = run([cli, "smooth", ridges_ply, "-o", out, "--iterations", "3"])
        assert r.returncode == 0, (r.returncode, r.stderr)
        _, _, before = read_ply_colors(ridges_ply)
        n, _, after = read_ply_colors(out)
        assert n == len(before) and after == before, "vertex colours changed"
    check("smooth carries a PLY input's vertex colours to PLY output", smooth_keeps_ply_colours)

    def smooth_names_what_it_drops():
        src = os.path.join(tmp, "parts.obj")
        with open(src, "w") as f:
            f.write("mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\nvt 0 0\nvt 1 0\nvt 1 1\n"
                    "usemtl skin\nf 1/1 2/2 3/3 4/1\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\nl 1 3\n")
        out = os.path.join(tmp, "parts-out.obj")
        r = run([cli, "smooth", src, "-o", out, "--flow", "laplacian", "--iterations", "1", "--json"])
        assert r.returncode == 0, (r.returncode, r.stderr)
        lines = [l for l in r.stderr.splitlines() if l.startswith("meshsmooth: warning:")]
        want = ("meshsmooth: warning: not kept: 1 OBJ line elements (l); 1 polygons triangulated; "
                "material library 'gone.mtl' (not found beside the input)")
        assert lines == [want], lines
        warnings = json.loads(r.stdout).get("warnings")
        assert warnings == ["not kept: 1 OBJ line elements (l)", "not kept: 1 polygons triangulated",
                            "not kept: material library 'gone.mtl' (not found beside the input)"], warnings
        with open(out) as f:
            text = f.read()
        assert "mtllib gone.mtl\n" in text and "usemtl skin\n" in text and "\nvt 1 1\n" in text, text[:300]
        assert "f 1/1 2/2 3/3\nf 1/1 3/3 4/1\n" in text, text
    check("smooth names what it cannot carry in one warning line and in the JSON; OBJ keeps vt and materials",
          smooth_names_what_it_drops)

    def render_png():
        png = os.path.join(tmp, "sphere.png")
        r = run([cli, "render", "builtin:noisy-sphere", "-o", png, "--size", "320x200"])
        assert r.returncode == 0, (r.returncode, r.stderr)
        assert f"wrote {png} (320x200)" in r.stdout, r.stdout
        width, height, rows = read_png(png)
        assert (width, height) == (320, 200), (width, height)
        assert rows[0][0] == (255, 255, 255), f"corner {rows[0][0]} is not the white background"
        assert rows[100][160] != (255, 255, 255), "nothing drawn at the centre"
    check("render writes a PNG of the asked size with the mesh in the middle", render_png)

    def render_bad_usage():
        png = os.path.join(tmp, "bad.png")
        for option, value in (("--size", "4x4"), ("--size", "320"), ("--view", "sideways")):
            r = run([cli, "render", "builtin:noisy-sphere", "-o", png, option, value])
            assert r.returncode == 2, (option, value, r.returncode, r.stderr)
            assert option in r.stderr, (option, value, r.stderr)
            assert not os.path.exists(png), (option, value)
        r = run([cli, "render", "--help"])
        assert r.returncode == 0, r.returncode
        for word in ("--view", "--size", "--shading"):
            assert word in r.stdout, f"'{word}' missing from render --help"
    check("render with a bad --size or --view exits 2 naming the option; --help lists them", render_bad_usage)

    def render_strength():
        png = os.path.join(tmp, "strength.png")
        # The unit sphere seen from the front (+x to the right): strength 1 where x >= 0.
        r = run([cli, "render", "builtin:sphere", "-o", png, "--size", "320x200", "--view", "front",
                 "--region", "box:0,-2,-2,2,2,2"])
        assert r.returncode == 0, (r.returncode, r.stderr)
        _, _, rows = read_png(png)
        left, right = rows[100][160 - 45], rows[100][160 + 45]
        assert left[0] == left[1] == left[2] and left != (255, 255, 255), f"strength 0 at {left}, not grey"
        assert right[0] > right[1] + 40 and right[1] > right[2] + 40, f"strength 1 at {right}, not orange"
        r = run([cli, "render", "builtin:sphere", "-o", png, "--falloff", "0.1"])
        assert r.returncode == 2 and "--falloff" in r.stderr, (r.returncode, r.stderr)
        r = run([cli, "render", "builtin:sphere", "-o", png, "--weight", "nope"])
        assert r.returncode == 1 and "--weight" in r.stderr, (r.returncode, r.stderr)
        r = run([cli, "render", "--help"])
        for word in ("--weight", "--fixed", "--region", "--outside", "--falloff"):
            assert word in r.stdout, f"'{word}' missing from render --help"
    check("render --region colours strength 0 grey and 1 orange; its flags are checked as smooth's",
          render_strength)

    beetle = shared_file(a.shared, "meshes", "beetle.obj")
    if beetle:
        def info_beetle():
            r = run([cli, "info", beetle])
            assert r.returncode == 0, r.stderr
            assert "non-manifold edges: 47" in r.stdout and "non-manifold vertices: 45" in r.stdout, r.stdout
        check("info reports the beetle's non-manifold edges and vertices", info_beetle)

    with Server(a.server, "--quiet") as server:
        address = server.address

        def through_server():
            out = os.path.join(tmp, "via_server.off")
            r = run([cli, "smooth", "builtin:noisy-plane", "-o", out, "--server", address, "--boundary", "curve"])
            assert r.returncode == 0, r.stderr
            with open(out) as f:
                assert f.readline().strip() == "OFF"
        check(f"smooth through meshsmoothd at {address}", through_server)

        def enhance_through_server():
            local, remote = os.path.join(tmp, "enhanced-local.ply"), os.path.join(tmp, "enhanced-remote.ply")
            r = run([cli, "enhance", "builtin:sphere", "-o", local, "--gain", "3", "--detail", "1", "-q"])
            assert r.returncode == 0, r.stderr
            r = run([cli, "enhance", "builtin:sphere", "-o", remote, "--gain", "3", "--detail", "1", "--json",
                     "--server", address])
            assert r.returncode == 0, r.stderr
            e = json.loads(r.stdout)["parameters"]["enhance"]
            assert e["gain"] == 3 and e["detail_scale"] == 1, e
            with open(local, "rb") as f1, open(remote, "rb") as f2:
                assert f1.read() == f2.read(), "the local and the server's results differ"
            r = run([cli, "enhance", "builtin:noisy-sphere", "-o", local, "--server", address])
            assert r.returncode == 1 and "the input is noisy" in r.stderr, (r.returncode, r.stderr)
            r = run([cli, "enhance", "builtin:sphere", "-o", local, "--gain", "1"])
            assert r.returncode == 2 and "enhance.gain" in r.stderr, (r.returncode, r.stderr)
            r = run([cli, "enhance", "builtin:sphere", "-o", local, "--detail", "big"])
            assert r.returncode == 2 and "--detail" in r.stderr, (r.returncode, r.stderr)
        check("enhance through meshsmoothd gives the local run's bytes; a noisy input exits 1 naming it, a gain of 1 "
              "or a bad --detail exits 2 naming it", enhance_through_server)

        def flows_are_the_servers():
            # meshsmoothd's ListFlows is the list: the CLI's in-process server offers the same
            # flows, in the same order.
            served = flow_names(cli, "--server", address)
            assert served and len(set(served)) == len(served), f"no flows or a name twice: {served}"
            embedded = flow_names(cli)
            assert embedded == served, f"embedded {embedded}, meshsmoothd {served}"
        check("flows --json lists every flow meshsmoothd's ListFlows reports", flows_are_the_servers)

        def huge_page_tunable():
            # base/huge_pages.h: the binaries re-execute themselves with glibc's THP tunable when
            # the kernel grants huge pages on request, and not when told otherwise.
            with open(f"/proc/{server.proc.pid}/environ", "rb") as f:
                env = f.read().split(b"\0")
            try:
                with open("/sys/kernel/mm/transparent_hugepage/enabled") as f:
                    madvise = "[madvise]" in f.read()
            except OSError:
                madvise = False
            expected = madvise and not a.sanitized
            # glibc edits the variable in place while parsing it: only its start is certain.
            tuned = any(e.startswith(b"GLIBC_TUNABLES=glibc.malloc.hugetlb=1") for e in env)
            assert tuned == expected, (expected, env)
            with Server(a.server, "--quiet", env=dict(os.environ, MESHSMOOTH_HUGE_PAGES="0")) as off:
                with open(f"/proc/{off.proc.pid}/environ", "rb") as f:
                    assert b"hugetlb" not in f.read()
        check("meshsmoothd runs with huge pages for large buffers where THP is on request, not with MESHSMOOTH_HUGE_PAGES=0",
              huge_page_tunable)

        def ctrl_c_cancels():
            # Taubin neither shrinks nor diverges: 10000 iterations on 40962 vertices take seconds.
            never = os.path.join(tmp, "never.ply")
            interrupt_long_job([cli, "smooth", "builtin:noisy-sphere-large", "-o", never, "--flow", "taubin",
                                "--iterations", "10000", "--server", address], never)
        check("Ctrl-C cancels the job and exits 130", ctrl_c_cancels)

    def plaintext_against_tls():
        cert, key = os.path.join(tmp, "tls.crt"), os.path.join(tmp, "tls.key")
        r = run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=localhost", "-addext",
                 "subjectAltName=DNS:localhost,IP:127.0.0.1", "-keyout", key, "-out", cert, "-days", "1"])
        assert r.returncode == 0, r.stderr
        with Server(a.server, "--quiet", "--tls-cert", cert, "--tls-key", key) as tls:
            r = run([cli, "smooth", "builtin:sphere", "-o", os.path.join(tmp, "plain.ply"), "--iterations", "1",
                     "--server", tls.address, "--retries", "0", "--timeout", "20"])
            assert r.returncode == 3, (r.returncode, r.stderr)
            assert "--tls-ca" in r.stderr, r.stderr
            grpc_lines = [l for l in r.stderr.splitlines() if re.match(r"^[DIWE]\d{4} \d\d:\d\d:\d\d", l)]
            assert not grpc_lines, f"gRPC's own log lines on stderr: {grpc_lines}"
            r = run([cli, "flows", "--server", tls.address, "--timeout", "20"])
            assert r.returncode == 3 and "--tls-ca" in r.stderr, (r.returncode, r.stderr)
            r = run([cli, "smooth", "builtin:sphere", "-o", os.path.join(tmp, "tls.ply"), "--iterations", "1",
                     "--server", f"localhost:{tls.port}", "--tls-ca", cert])
            assert r.returncode == 0, (r.returncode, r.stderr)
        with Server(a.server, "--quiet") as plain:
            # The other way round: gRPC logs the failed handshake itself, which the CLI keeps quiet.
            r = run([cli, "smooth", "builtin:sphere", "-o", os.path.join(tmp, "tls2.ply"), "--iterations", "1",
                     "--server", f"localhost:{plain.port}", "--tls-ca", cert, "--retries", "0", "--timeout", "20"])
            assert r.returncode == 3, (r.returncode, r.stderr)
            assert "may not use TLS" in r.stderr, r.stderr
            grpc_lines = [l for l in r.stderr.splitlines() if re.match(r"^[DIWE]\d{4} \d\d:\d\d:\d\d", l)]
            assert not grpc_lines, f"gRPC's own log lines on stderr: {grpc_lines}"
    check("a plaintext client against a TLS server or a TLS client against a plaintext one: exit 3 with a hint, "
          "no gRPC log lines on stderr", plaintext_against_tls)

    def token_files_trimmed_alike():
        # The server and the CLI read a token file by one rule: whitespace at both ends dropped.
        server_token = write_text(os.path.join(tmp, "server.token"), "s3cret-token\n")
        client_token = write_text(os.path.join(tmp, "client.token"), "  s3cret-token \t \n")
        wrong_token = write_text(os.path.join(tmp, "wrong.token"), "s3cret-tokem\n")
        with Server(a.server, "--quiet", "--auth-token-file", server_token) as guarded:
            guarded_address = guarded.address
            out = os.path.join(tmp, "with_token.ply")
            r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out, "--iterations", "3", "--server", guarded_address,
                     "--token-file", client_token])
            assert r.returncode == 0, (r.returncode, r.stderr)
            assert ply_counts(out) == (2562, 5120), ply_counts(out)
            assert "3 of 3 iterations" in r.stdout, r.stdout
            r = run([cli, "smooth", "builtin:noisy-sphere", "-o", os.path.join(tmp, "wrong_token.ply"), "--iterations",
                     "3", "--server", guarded_address, "--token-file", wrong_token])
            assert r.returncode == 1, (r.returncode, r.stderr)
            assert "UNAUTHENTICATED" in r.stderr, r.stderr
            assert not os.path.exists(os.path.join(tmp, "wrong_token.ply"))
    check("a token file with spaces around the token works from the CLI; a wrong token exits 1 (UNAUTHENTICATED)",
          token_files_trimmed_alike)


if __name__ == "__main__":
    sys.exit(main())
