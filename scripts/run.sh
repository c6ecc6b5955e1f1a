#!/usr/bin/env bash
# The main job: builds if needed, starts meshsmoothd on a free local port, smooths the
# built-in default input (a noisy icosphere) through it with the meshsmooth client (the default
# job: no parameters), shows the
# job summary, and stops the server. The result is written to build/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh dev >/dev/null
mkdir -p build/demo
log=build/demo/meshsmoothd.log
build/server/meshsmoothd --listen 127.0.0.1:0 >build/demo/meshsmoothd.out 2>"$log" &
server=$!
trap 'kill -TERM $server 2>/dev/null; wait $server 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  grep -q "listening on" build/demo/meshsmoothd.out 2>/dev/null && break
  kill -0 $server 2>/dev/null || { cat "$log" >&2; exit 1; }
  sleep 0.1
done
address=$(sed -n 's/^meshsmoothd listening on //p' build/demo/meshsmoothd.out)
echo "meshsmoothd is listening on $address"
echo "\$ meshsmooth smooth builtin:noisy-sphere -o build/demo/noisy-sphere-smoothed.ply --server $address"
build/client/meshsmooth smooth builtin:noisy-sphere -o build/demo/noisy-sphere-smoothed.ply --server "$address"
echo "server log:"
cat "$log"
