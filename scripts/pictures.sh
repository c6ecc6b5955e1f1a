#!/usr/bin/env bash
# The README's pictures, made with `meshsmooth render` (runs locally; needs the shared test meshes,
# docs/development.md "Data", or MESHES=DIR):
#   docs/images/bunny-before.png   the Stanford bunny as scanned (zipper output, scanner noise)
#   docs/images/bunny-after.png    the same after 20 iterations of the paper's flow (median)
#   docs/images/fandisk-noisy.png  the fandisk with Gaussian noise of 0.2 mean edges along its
#                                  normals, seed 1: the quality benchmark's input
#                                  (meshsmooth_quality --write-noisy)
#   docs/images/fandisk-paper.png  that input after the paper's best flow there by RMS distance in
#                                  docs/quality.md (bilaplacian, 12 iterations)
#   docs/images/fandisk-guided.png the same input after guided_normal, automatic stopping
#   docs/images/fandisk-ridges.png ridges (black) and ravines (white) of that result, features with
#                                  |curvature| > 20 only
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
build/bench/meshsmooth_quality --shared "$(dirname "$meshes")/.." --write-noisy fandisk 0.2 1 "$tmp/fandisk-noisy.ply"
$cli render "$tmp/fandisk-noisy.ply" -o "$out/fandisk-noisy.png" --view iso --size 480x480 --shading flat
$cli smooth "$tmp/fandisk-noisy.ply" -o "$tmp/fandisk-paper.ply" --flow bilaplacian --iterations 12 --quiet
$cli render "$tmp/fandisk-paper.ply" -o "$out/fandisk-paper.png" --view iso --size 480x480 --shading flat
$cli smooth "$tmp/fandisk-noisy.ply" -o "$tmp/fandisk-guided.ply" --flow guided_normal --quiet
$cli render "$tmp/fandisk-guided.ply" -o "$out/fandisk-guided.png" --view iso --size 480x480 --shading flat
$cli ridges "$tmp/fandisk-guided.ply" -o "$tmp/fandisk-ridges.ply" --threshold 20
$cli render "$tmp/fandisk-ridges.ply" -o "$out/fandisk-ridges.png" --view iso --size 480x480
