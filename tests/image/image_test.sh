#!/usr/bin/env bash
# The container image for real: builds docker/Dockerfile with buildah (no container daemon, no
# registry), runs the image's meshsmoothd and smooths meshes through it.
#
#   tests/image/image_test.sh [--cli PATH]      (root; default CLI: build/client/meshsmooth)
#
# 1. Installs podman, buildah and debootstrap when missing, and gives containers.conf the
#    default_ulimits this kind of VM needs (it allows no new rlimits; left alone when set).
# 2. Makes the base images debian:bookworm and debian:bookworm-slim (one image, two tags) from
#    the Debian archive apt uses here: debootstrap --variant=minbase, then podman import. The
#    root file system is kept as a tarball in $MESHSMOOTH_IMAGE_CACHE (default
#    /var/cache/meshsmooth-image); nothing is done when both images exist.
# 3. buildah bud --isolation chroot --network host --layers (nice -n 10): the image
#    $MESHSMOOTH_IMAGE (default localhost/meshsmoothd:test), its build stage tagged
#    ...-build:test. --layers keeps each step as a layer, so a rebuild after a source change
#    starts from the compile; then podman image prune removes dangling images (earlier builds).
# 4. Runs the image's meshsmoothd as its user (buildah run --isolation chroot, host network, port
#    0), then checks: the image's user and entrypoint; `meshsmoothd --help` as that user; the
#    server process runs as that user; the host's CLI smooths builtin:noisy-sphere through it
#    and the image's CLI a generated OBJ file (mounted in), each giving the same bytes as the
#    host's CLI in-process (results are deterministic) and a result `meshsmooth info` reads
#    with the input's vertex count; the image's CLI in-process gives them too; the server's log
#    names both jobs; SIGTERM stops it with exit 0 within 15 s.
# Prints each check, the time of each stage, and "image: N passed, N failed"; exits 1 on any
# failure. The containers and the temporary directory are removed on exit, whatever happened.
# Not a ctest test: it needs root, installs packages and takes ~4 min cold; .ci/run runs it.
set -euo pipefail
cd "$(dirname "$0")/../.."

cli=build/client/meshsmooth
if [ "${1:-}" = --cli ] && [ -n "${2:-}" ]; then cli=$2; elif [ $# -gt 0 ]; then
  echo "usage: tests/image/image_test.sh [--cli PATH]" >&2; exit 2
fi
cache=${MESHSMOOTH_IMAGE_CACHE:-/var/cache/meshsmooth-image}
image=${MESHSMOOTH_IMAGE:-localhost/meshsmoothd:test}
base=docker.io/library/debian
uid=10001   # docker/Dockerfile's useradd --uid

passed=0
failed=0
ok() { echo "ok: $*"; passed=$((passed + 1)); }
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }
die() { fail "$*"; exit 1; }

# Stage times: "== NAME" when one starts, "-- NAME: S s" when it ends, all of them at exit.
stage_name=""
stage_start=0
stage_times=()
now() { date +%s.%N; }
end_stage() {
  [ -n "$stage_name" ] || return 0
  local t
  t=$(awk -v a="$stage_start" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }')
  echo "-- $stage_name: $t s"
  stage_times+=("$(printf '%-28s %8s s' "$stage_name" "$t")")
  stage_name=""
}
stage() { end_stage; stage_name=$1; stage_start=$(now); echo "== $1"; }

tmp=""
server_pid=""     # the background `buildah run` of the server
containers=()
cleanup() {
  local rc=$?
  set +e
  end_stage
  if [ -n "$server_pid" ] && kill -0 "$server_pid" 2>/dev/null; then
    local d
    for d in $(descendants "$server_pid"); do kill -KILL "$d" 2>/dev/null; done
    kill -KILL "$server_pid" 2>/dev/null
    wait "$server_pid" 2>/dev/null
  fi
  local c
  for c in "${containers[@]}"; do buildah rm "$c" >/dev/null 2>&1; done
  if [ -n "$tmp" ]; then
    if [ "$failed" -gt 0 ] && [ -s "$tmp/server.err" ]; then
      echo "--- the server's stderr:"; tail -n 40 "$tmp/server.err"
    fi
    rm -rf "$tmp"
  fi
  echo "stage times:"
  local line
  for line in "${stage_times[@]}"; do echo "  $line"; done
  [ "$rc" -eq 0 ] || [ "$failed" -gt 0 ] || fail "stopped by an error (exit $rc)"
  echo "image: $passed passed, $failed failed"
  [ "$failed" -eq 0 ] && exit 0
  exit 1
}
trap cleanup EXIT

# Every process below PID (its children, theirs, ...), from /proc (procps need not be there).
children() {
  local s
  for s in /proc/[0-9]*/stat; do
    # Field 4 of stat is the parent; field 2, the name in parentheses, may hold spaces.
    awk -v parent="$1" '{ sub(/^.*\) /, ""); if ($2 == parent) { split(FILENAME, f, "/"); print f[3] } }' "$s" 2>/dev/null
  done
}
descendants() {
  local p
  for p in $(children "$1"); do echo "$p"; descendants "$p"; done
}

# The first archive URI apt uses here for SUITE (one-line .list files and deb822 .sources),
# so debootstrap reaches the archive wherever apt does.
apt_uri() {
  python3 - "$1" <<'EOF'
import glob, re, sys
suite = sys.argv[1]
def entries():
    for f in ["/etc/apt/sources.list"] + sorted(glob.glob("/etc/apt/sources.list.d/*.list")):
        try:
            lines = open(f).read().splitlines()
        except OSError:
            continue
        for line in lines:
            m = re.match(r"deb\s+(\[[^]]*\]\s+)?(\S+)\s+(\S+)", line.split("#", 1)[0].strip())
            if m:
                yield m.group(2), [m.group(3)]
    for f in sorted(glob.glob("/etc/apt/sources.list.d/*.sources")):
        for stanza in re.split(r"\n[ \t]*\n", open(f).read()):
            fields = {}
            for line in stanza.splitlines():
                if line[:1] in ("#", " ", "\t") or ":" not in line:
                    continue  # comments and continuation lines (keys)
                key, value = line.split(":", 1)
                fields[key.strip().lower()] = value.split()
            if "deb" in fields.get("types", []) and fields.get("enabled", ["yes"])[0].lower() != "no":
                for uri in fields.get("uris", []):
                    yield uri, fields.get("suites", [])
for uri, suites in entries():
    if suite in suites:
        print(uri.rstrip("/"))
        break
EOF
}

[ "$(id -u)" -eq 0 ] || { echo "image_test: needs root (apt-get, debootstrap, buildah)" >&2; exit 2; }
[ -x "$cli" ] || { echo "image_test: no CLI at $cli (scripts/setup.sh builds it)" >&2; exit 2; }
cli=$(realpath "$cli")
tmp=$(mktemp -d /tmp/meshsmooth-image-test.XXXXXX)
chmod 0777 "$tmp"   # mounted into the containers, where the CLI writes as uid $uid

# ---- 1. tools
stage "tools"
missing=()
for p in podman buildah debootstrap; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing ${missing[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi
conf=/etc/containers/containers.conf
if ! grep -qs '^[[:space:]]*default_ulimits' "$conf"; then
  mkdir -p /etc/containers
  if grep -qs '^\[containers\]' "$conf"; then
    sed -i '/^\[containers\]/a default_ulimits = ["nofile=20000:20000", "nproc=32768:32768"]' "$conf"
  else
    printf '[containers]\ndefault_ulimits = ["nofile=20000:20000", "nproc=32768:32768"]\n' >>"$conf"
  fi
  echo "wrote default_ulimits to $conf"
fi
echo "$(buildah --version); $(podman --version)"

# ---- 2. base images
stage "base images"
if podman image exists "$base:bookworm" && podman image exists "$base:bookworm-slim"; then
  echo "$base:bookworm and :bookworm-slim exist"
else
  rootfs_tar=$cache/debian-bookworm-minbase.tar
  if [ ! -s "$rootfs_tar" ]; then
    mirror=$(apt_uri bookworm)
    mirror=${mirror:-http://deb.debian.org/debian}
    security=$(apt_uri bookworm-security)
    echo "debootstrap --variant=minbase bookworm from $mirror"
    mkdir -p "$cache"
    rootfs=$(mktemp -d "$cache/rootfs.XXXXXX")
    include=()
    [[ "$mirror" != https:* ]] || include=(--include=ca-certificates)
    if ! debootstrap --variant=minbase "${include[@]}" bookworm "$rootfs" "$mirror" >"$tmp/debootstrap.log" 2>&1; then
      tail -n 30 "$tmp/debootstrap.log"; rm -rf "$rootfs"; die "debootstrap failed"
    fi
    # The suites Debian's own image lists: the release, its updates, and security if apt here has it.
    { echo "deb $mirror bookworm main"
      echo "deb $mirror bookworm-updates main"
      [ -z "$security" ] || echo "deb $security bookworm-security main"
    } >"$rootfs/etc/apt/sources.list"
    rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*
    tar --numeric-owner -C "$rootfs" -cf "$rootfs_tar.part" .
    mv "$rootfs_tar.part" "$rootfs_tar"
    rm -rf "$rootfs"
  else
    echo "root file system from $rootfs_tar"
  fi
  podman import --quiet --change 'ENV=PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
    --change 'CMD=["bash"]' "$rootfs_tar" "$base:bookworm" >/dev/null
  podman tag "$base:bookworm" "$base:bookworm-slim"
  echo "imported $base:bookworm, tagged $base:bookworm-slim"
fi

# ---- 3. the image
stage "image build"
# The build stage gets a tag of its own ($image-build): its layers, the next build's cache, then
# outlive the prune below, which removes the layers of earlier builds (untagged, unused).
build_image=${image%:*}-build:${image##*:}
bud=(nice -n 10 buildah bud --isolation chroot --network host --layers --pull=never -f docker/Dockerfile)
for target in build runtime; do
  t0=$(now)
  if [ "$target" = build ]; then args=(--target build -t "$build_image"); else args=(-t "$image"); fi
  if ! "${bud[@]}" "${args[@]}" . >>"$tmp/build.log" 2>&1; then
    echo "--- the end of the build's output:"; tail -n 60 "$tmp/build.log"
    die "buildah bud -f docker/Dockerfile ${args[*]} failed"
  fi
  awk -v a="$t0" -v b="$(now)" -v s="${args[*]}" 'BEGIN { printf "buildah bud %s: %.1f s\n", s, b - a }'
done
ok "buildah bud built $image"
podman image prune -f >/dev/null
user=$(buildah inspect --type image --format '{{.OCIv1.Config.User}}' "$image")
entry=$(buildah inspect --type image --format '{{.OCIv1.Config.Entrypoint}}' "$image")
[ "$user" = meshsmooth ] && [ "$entry" = "[meshsmoothd --listen 0.0.0.0:50051]" ] \
  && ok "the image runs '$entry' as user $user" \
  || fail "image config: user '$user', entrypoint '$entry'"

# ---- 4. the server
stage "server start"
container=""
new_container() { container=$(buildah from --pull=never "$image"); containers+=("$container"); }
# run_in CONTAINER COMMAND...: as the image's user, on the host's network, with $tmp at /data.
run_args=(--isolation chroot --network host --user meshsmooth -v "$tmp:/data")
run_in() { local c=$1; shift; timeout 300 buildah run "${run_args[@]}" "$c" -- "$@"; }
new_container; server_c=$container
new_container; client_c=$container

help=$(run_in "$client_c" sh -c 'id -u; meshsmoothd --help' 2>&1) \
  && [ "$(head -n 1 <<<"$help")" = "$uid" ] && grep -q -- '--listen' <<<"$help" \
  && ok "meshsmoothd --help runs as uid $uid" \
  || fail "meshsmoothd --help as the image's user: $(head -n 5 <<<"$help")"

buildah run "${run_args[@]}" "$server_c" -- meshsmoothd --listen 127.0.0.1:0 --workers 2 >"$tmp/server.out" 2>"$tmp/server.err" &
server_pid=$!
port=""
for _ in $(seq 600); do
  port=$(sed -n 's/^meshsmoothd listening on 127\.0\.0\.1:\([0-9][0-9]*\)$/\1/p' "$tmp/server.out")
  [ -z "$port" ] || break
  kill -0 "$server_pid" 2>/dev/null || break
  sleep 0.1
done
[ -n "$port" ] || die "the image's meshsmoothd did not print 'meshsmoothd listening on' within 60 s"
ok "the image's meshsmoothd listens on 127.0.0.1:$port"
# The server itself, below buildah run and buildah-chroot-exec (its name is "exe": it
# re-executes itself through /proc/self/exe, base/huge_pages.h).
daemon_pid=""
for p in $(descendants "$server_pid"); do
  [[ "$(readlink "/proc/$p/exe" 2>/dev/null)" != */usr/local/bin/meshsmoothd ]] || daemon_pid=$p
done
[ -n "$daemon_pid" ] && [ "$(awk '/^Uid:/ { print $2 }' "/proc/$daemon_pid/status")" = "$uid" ] \
  && ok "the server process $daemon_pid runs as uid $uid" \
  || fail "no meshsmoothd process of uid $uid below buildah run (pid $server_pid)"

# ---- 5. jobs
stage "jobs"
# sha256 of FILE, and its vertex count as `meshsmooth info` reads it.
digest() { sha256sum "$1" | cut -d' ' -f1; }
vertices() { "$cli" info "$1" | sed -n 's/^vertices: //p'; }

# A noisy 40 x 30 height field as OBJ (a boundary, so the job differs from the sphere's).
python3 - "$tmp/field.obj" <<'EOF'
import math, random, sys
rng = random.Random(21)
nx, ny = 40, 30
with open(sys.argv[1], "w") as f:
    for j in range(ny):
        for i in range(nx):
            x, y = i / (nx - 1), j / (ny - 1)
            z = 0.2 * math.sin(3 * x) * math.cos(2 * y) + rng.uniform(-0.008, 0.008)
            f.write(f"v {x:.6f} {y:.6f} {z:.6f}\n")
    for j in range(ny - 1):
        for i in range(nx - 1):
            a = j * nx + i + 1
            f.write(f"f {a} {a + 1} {a + nx + 1}\nf {a} {a + nx + 1} {a + nx}\n")
EOF
chmod 0644 "$tmp/field.obj"

# The references: the host's CLI in-process (no server).
timeout 300 "$cli" smooth builtin:noisy-sphere -o "$tmp/sphere-ref.ply" --quiet \
  || die "reference job: meshsmooth smooth builtin:noisy-sphere (in-process) failed"
timeout 300 "$cli" smooth "$tmp/field.obj" -o "$tmp/field-ref.ply" --quiet \
  || die "reference job: meshsmooth smooth field.obj (in-process) failed"

# check_result LABEL RESULT REFERENCE VERTICES: the same bytes as the in-process reference,
# and `meshsmooth info` reads VERTICES vertices back.
check_result() {
  local label=$1 result=$2 reference=$3 want=$4 n
  [ "$(digest "$result")" = "$(digest "$reference")" ] \
    && ok "$label: the same bytes as the host's CLI in-process ($(digest "$reference" | cut -c1-16))" \
    || fail "$label: the result differs from the host's in-process one"
  n=$(vertices "$result")
  [ "$n" = "$want" ] && ok "$label: the result reads back with $want vertices" \
    || fail "$label: the result reads back with '$n' vertices, not $want"
}

# The host's CLI through the image's server.
if timeout 300 "$cli" smooth builtin:noisy-sphere -o "$tmp/sphere-host.ply" --server "127.0.0.1:$port" \
    --job-id image-test-host-cli --timeout 240 --json >"$tmp/sphere-host.json"; then
  ok "host CLI -> image's server: builtin:noisy-sphere smoothed ($(python3 -c \
    'import json,sys; p=json.load(open(sys.argv[1]))["parameters"]; print(p["flow"], p["iterations_run"], "iterations")' \
    "$tmp/sphere-host.json"))"
  check_result "host CLI -> image's server" "$tmp/sphere-host.ply" "$tmp/sphere-ref.ply" 2562
else
  fail "host CLI -> image's server: meshsmooth smooth builtin:noisy-sphere failed"
fi

# The image's CLI through the image's server, on the file.
if run_in "$client_c" meshsmooth smooth /data/field.obj -o /data/field-image.ply \
    --server "127.0.0.1:$port" --job-id image-test-image-cli --timeout 240 --quiet; then
  ok "image's CLI -> image's server: field.obj (1200 vertices) smoothed"
  check_result "image's CLI -> image's server" "$tmp/field-image.ply" "$tmp/field-ref.ply" 1200
else
  fail "image's CLI -> image's server: meshsmooth smooth /data/field.obj failed"
fi

# The image's CLI alone (in-process server).
run_in "$client_c" meshsmooth smooth /data/field.obj -o /data/field-image-local.ply --quiet \
  && [ "$(digest "$tmp/field-image-local.ply")" = "$(digest "$tmp/field-ref.ply")" ] \
  && ok "image's CLI in-process: the same bytes as the host's" \
  || fail "image's CLI in-process: failed or a different result"

for id in image-test-host-cli image-test-image-cli; do
  grep -q "job=$id " "$tmp/server.err" "$tmp/server.out" \
    && ok "the server's log has job $id" || fail "the server's log has no line for job $id"
done

# ---- 6. shutdown
# To meshsmoothd itself, as `docker stop` sends it to a container's first process: SIGTERM to
# `buildah run` would kill its child with SIGKILL instead of passing the signal on.
stage "shutdown"
if [ -n "$daemon_pid" ]; then
  kill -TERM "$daemon_pid"
  for _ in $(seq 150); do kill -0 "$server_pid" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$server_pid" 2>/dev/null; then
    fail "meshsmoothd still runs 15 s after SIGTERM"
  else
    rc=0; wait "$server_pid" || rc=$?
    server_pid=""
    [ "$rc" -eq 0 ] && grep -q "meshsmoothd: stopped" "$tmp/server.err" \
      && ok "SIGTERM: meshsmoothd stopped, exit 0" \
      || fail "SIGTERM: exit $rc, stderr: $(tail -n 3 "$tmp/server.err")"
  fi
else
  fail "SIGTERM: no server process to send it to"
fi
