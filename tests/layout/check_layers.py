#!/usr/bin/env python3
"""Checks that no #include runs back up the project's layers, that core reads no environment, and
that the default job keeps its tuned numbers in JobPolicy (core/job/policy.h).

The rooms, lowest first (a file may include its own room and any lower layer, nothing else):
  core/util                               stop token, radix sort
  core                                    the mesh model: mesh, vec3, topology, normals, weld
  core/io, core/measure                   files and the Draco codec; metrics, distances, noise
  core/shapes, core/features, core/flows, core/render
  core/job                                the default job (the front door, Smooth(), is its)
  base                                    process-wide plumbing the programs link
  server                                  the gRPC service
  client                                  the CLI and its client library
  bench, fuzz, python                     tools on top of everything; python the Python package's extension
  tests                                   the tests, which may test the tools' own generators

Exit status 1 and one line per offending include when a file breaks the order.
"""
import argparse
import pathlib
import re
import sys

LAYERS = [
    ["core/util"],
    ["core"],
    ["core/io", "core/measure"],
    ["core/shapes", "core/features", "core/flows", "core/render"],
    ["core/job"],
    ["base"],
    ["server"],
    ["client"],
    ["bench", "fuzz", "python"],
    ["tests"],
]
RANK = {room: rank for rank, rooms in enumerate(LAYERS) for room in rooms}
TOP = {"core", "base", "server", "client", "bench", "fuzz", "python", "tests"}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.MULTILINE)


def room_of(path: str) -> str:
    parts = path.split("/")
    if parts[0] == "core" and len(parts) > 2:
        return "core/" + parts[1]
    return parts[0]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", default=pathlib.Path(__file__).resolve().parents[2], type=pathlib.Path)
    args = parser.parse_args()
    bad = []
    for top in sorted(TOP):
        for f in sorted((args.root / top).rglob("*")):
            if f.suffix not in (".h", ".cc"):
                continue
            rel = f.relative_to(args.root).as_posix()
            own = room_of(rel)
            if own not in RANK:
                bad.append(f"{rel}: room {own} is in no layer (tests/layout/check_layers.py)")
                continue
            for inc in INCLUDE.findall(f.read_text(errors="replace")):
                if inc.split("/")[0] not in TOP:
                    continue  # third-party or generated (meshsmooth/v1/...)
                other = room_of(inc)
                if other == own:
                    continue
                if other not in RANK or RANK[other] >= RANK[own]:
                    bad.append(f"{rel}: includes {inc} ({other} is not below {own})")
    # The core library takes its settings as arguments: no process environment read inside it
    # (the programs read theirs in base/, e.g. base/kernel_environment.h).
    for f in sorted((args.root / "core").rglob("*")):
        if f.suffix in (".h", ".cc") and re.search(r"\bgetenv\s*\(", f.read_text(errors="replace")):
            bad.append(f"{f.relative_to(args.root).as_posix()}: reads the environment (getenv) inside core")
    # The default job's tuned numbers are the fields of JobPolicy (core/job/policy.h), one line
    # each: no named constant elsewhere in its room.
    for f in sorted((args.root / "core" / "job").rglob("*")):
        if f.suffix in (".h", ".cc") and f.name != "policy.h":
            for line in f.read_text(errors="replace").splitlines():
                if re.match(r"\s*(static\s+|inline\s+)*constexpr\s", line):
                    bad.append(f"{f.relative_to(args.root).as_posix()}: a constant outside JobPolicy: {line.strip()}")
    # ... and VisitPolicy (the benchmark's --policy and --list-policy) visits every one, in order; the
    # noise estimator's tuned numbers are the fields of NoiseParams (core/measure/noise.h), which it
    # visits as noise.NAME, and noise.{h,cc} name no other constant but mathematics and bounds on work.
    policy_h = (args.root / "core" / "job" / "policy.h").read_text(errors="replace")
    noise_h = (args.root / "core" / "measure" / "noise.h").read_text(errors="replace")
    for struct_name, text, member in (("JobPolicy", policy_h, ""), ("NoiseParams", noise_h, "noise.")):
        struct = re.search(r"struct %s \{(.*?)\n\};" % struct_name, text, re.S)
        fields = re.findall(r"^\s+(?:double|int|int32_t)\s+(\w+)\s*=", struct.group(1), re.M) if struct else []
        visited = re.findall(r'visit\("%s(\w+)",\s*policy\.%s(\w+)\)' % (re.escape(member), re.escape(member)),
                             policy_h)
        if not fields or [name for name, _ in visited] != fields or any(n != m for n, m in visited):
            bad.append(f"core/job/policy.h: VisitPolicy visits {member}{[n for n, _ in visited]}, "
                       f"{struct_name} has {fields}")
    allowed = {"kTerms", "kMinRelativePivot", "kMadToSigma", "kTrimSigmas", "kTrimmedSecondMoment", "kUnusable",
               "kMaxGather", "kWideGather", "kMinParallelFits"}
    for name in ("noise.h", "noise.cc"):
        for line in (args.root / "core" / "measure" / name).read_text(errors="replace").splitlines():
            m = re.match(r"\s*(?:static\s+|inline\s+)*constexpr\s+[\w:]+\s+(\w+)\s*=", line)
            if m and m.group(1) not in allowed:
                bad.append(f"core/measure/{name}: a tuned constant outside NoiseParams: {line.strip()}")
    for line in bad:
        print(line)
    print(f"check_layers: {len(bad)} problem(s)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
