#!/usr/bin/env bash
# Peak resident memory per vertex of one job in meshsmoothd, the figure deploy/kubernetes/
# sizes its memory limit from: starts a fresh meshsmoothd (one worker), sends one job with the
# CLI, and prints (VmHWM after the job - VmRSS before it) / vertices, from /proc/PID/status.
# Usage: scripts/peak-memory.sh MESH [THREADS_PER_JOB [smooth options...]]   (after scripts/setup.sh)
#   e.g. scripts/peak-memory.sh ../shared/data/meshes/stanford-dragon.ply 2 --flow guided_normal
set -euo pipefail
mesh="$1"
threads="${2:-1}"
shift $(( $# < 2 ? $# : 2 ))
build="$(cd "$(dirname "$0")/.." && pwd)/build"
work=$(mktemp -d)
server=""
trap '[ -z "$server" ] || kill "$server" 2>/dev/null || true; rm -rf "$work"' EXIT

"$build/server/meshsmoothd" --listen 127.0.0.1:0 --workers 1 --threads-per-job "$threads" --quiet \
  > "$work/out" 2> "$work/log" &
server=$!
port=""
for _ in $(seq 100); do
  port=$(sed -n 's/^meshsmoothd listening on .*:\([0-9]*\)$/\1/p' "$work/out")
  [ -z "$port" ] || break
  sleep 0.1
done
[ -n "$port" ] || { echo "meshsmoothd did not start" >&2; exit 1; }
idle_kib=$(awk '/^VmRSS:/ {print $2}' "/proc/$server/status")
"$build/client/meshsmooth" smooth "$mesh" -o "$work/result.drc" --server "127.0.0.1:$port" --quiet "$@"
peak_kib=$(awk '/^VmHWM:/ {print $2}' "/proc/$server/status")
vertices=$("$build/client/meshsmooth" info "$mesh" | sed -n 's/^vertices: //p')
echo "$(basename "$mesh") ${*:-(default job)}, $threads thread(s): $vertices vertices," \
  "idle $((idle_kib / 1024)) MiB, peak $((peak_kib / 1024)) MiB," \
  "$(( (peak_kib - idle_kib) * 1024 / vertices )) bytes per vertex"
