#!/usr/bin/env bash
# The scan pictures of docs/quality.md and the default job on the real scans without a reference,
# made with `meshsmooth render` and `meshsmooth smooth` (runs locally):
#   docs/images/scan-sl-frame.png      a simulated structured-light frame of the fandisk (the
#                                      benchmark's held-out scan 0: meshsmooth_quality --write-scan)
#   docs/images/scan-fused.png         a simulated fused scan of the fandisk (held-out scan 0)
#   docs/images/real-NAME-before.png   angel, iron and rabbit of ../shared/data/real as scanned
#   docs/images/real-NAME-after.png    the same after the default job (`meshsmooth smooth IN -o OUT`)
# and prints, as Markdown, what the default job did to each real scan (from the CLI's --json). The real scans are
# read from DIR/data/real (SHARED=DIR, default ../shared), decompressed into a temporary folder;
# when that folder is absent they are skipped with a message.
set -euo pipefail
cd "$(dirname "$0")/.."
shared=${SHARED:-../shared}
cli=build/client/meshsmooth
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
build/bench/meshsmooth_quality --shared "$shared" --write-scan fandisk sl 0 "$tmp/sl.ply"
$cli render "$tmp/sl.ply" -o "$out/scan-sl-frame.png" --view 65,25 --size 480x480 --shading flat >/dev/null
build/bench/meshsmooth_quality --shared "$shared" --write-scan fandisk fused 0 "$tmp/fused.ply"
$cli render "$tmp/fused.ply" -o "$out/scan-fused.png" --view 65,25 --size 480x480 --shading flat >/dev/null
real="$shared/data/real"
if [[ ! -d "$real" ]]; then
  echo "real scans skipped: $real absent" >&2
  exit 0
fi
echo "| real scan | flow | iterations | stop reason | noise estimate (h) | RMS move (h) |"
echo "|---|---|---|---|---|---|"
for name in angel.obj iron.ply rabbit.obj; do
  base=${name%.*}
  xz -dc "$real/$name.xz" >"$tmp/$name"
  $cli render "$tmp/$name" -o "$out/real-$base-before.png" --view front --size 480x480 --shading flat >/dev/null
  $cli smooth "$tmp/$name" -o "$tmp/after-$name" --json >"$tmp/$base.json"
  $cli render "$tmp/after-$name" -o "$out/real-$base-after.png" --view front --size 480x480 --shading flat >/dev/null
  /usr/bin/python3 - "$tmp/$base.json" "$base" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
p = d["parameters"]
h = p.get("mean_edge_length") or float("nan")
move = d.get("rms_displacement", 0.0) / h
print("| %s | %s | %d | %s | %.3f | %.3f |" % (sys.argv[2], p.get("flow"), p.get("iterations_run", 0),
                                             p.get("stop_reason"), p.get("noise_estimate", float("nan")), move))
PY
done
