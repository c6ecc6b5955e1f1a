#!/usr/bin/env bash
# The README's pictures, made with `meshsmooth render` (runs locally; needs the shared test meshes,
# docs/development.md "Data", or MESHES=DIR):
#   docs/images/bunny-before.png   the Stanford bunny as scanned (zipper output, scanner noise)
#   docs/images/bunny-after.png    the same after 20 iterations of the paper's flow (median)
#   docs/images/fandisk-ridges.png ridges (black) and ravines (white) of the fandisk after 5
#                                  iterations of median, features with |curvature| > 20 only
set -euo pipefail
cd "$(dirname "$0")/.."
meshes=${MESHES:-../shared/data/meshes}
cli=build/client/meshsmooth
out=docs/images
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
set -x
$cli render "$meshes/stanford-bunny.ply" -o "$out/bunny-before.png" --view front --size 480x480
$cli smooth "$meshes/stanford-bunny.ply" -o "$tmp/bunny-median.ply" --flow median --iterations 20 --quiet
$cli render "$tmp/bunny-median.ply" -o "$out/bunny-after.png" --view front --size 480x480
$cli smooth "$meshes/fandisk.obj" -o "$tmp/fandisk-ridges.ply" --flow median --iterations 5 \
  --ridges --ridge-threshold 20 --quiet
$cli render "$tmp/fandisk-ridges.ply" -o "$out/fandisk-ridges.png" --view iso --size 480x480
