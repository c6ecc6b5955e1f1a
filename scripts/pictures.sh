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
#   docs/images/bunny-textured-before.png  the bunny as scanned, as a textured scan: per-vertex
#                                  texture coordinates (a front projection) and a checkerboard of
#                                  them as vertex colours
#   docs/images/bunny-textured-after.png   that PLY after 20 iterations of median: the texture
#                                  coordinates and colours come back on the smoothed surface
#   docs/images/rabbit-region-before.png   the real rabbit scan (../shared/data/real, REAL=DIR) with
#                                  the strength of a sphere around its head as colour (grey 0,
#                                  orange 1; `render --region`)
#   docs/images/rabbit-region-after.png    after the default job with that region: the head smoothed,
#                                  the rest as scanned
#   docs/images/bunny-worn.png     the Stanford bunny worn: 10 iterations of laplacian wipe out its
#                                  relief (the scan's ridges and bumps)
#   docs/images/bunny-enhanced.png that worn bunny enhanced back (`meshsmooth enhance --gain 3
#                                  --detail 6h`: screened-Poisson sharpening below 6 mean edges)
set -euo pipefail
cd "$(dirname "$0")/.."
meshes=${MESHES:-../shared/data/meshes}
real=${REAL:-../shared/data/real}
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
# A textured scan: s t from a front projection and an 8 x 8 checkerboard of them as colours.
/usr/bin/python3 - "$meshes/stanford-bunny.ply" "$tmp/bunny-textured.ply" <<'PY'
import sys
lines = open(sys.argv[1]).read().splitlines()
end = lines.index("end_header")
nv = int(next(l.split()[2] for l in lines if l.startswith("element vertex")))
verts = [tuple(map(float, l.split()[:3])) for l in lines[end + 1:end + 1 + nv]]
faces = lines[end + 1 + nv:]
lo = [min(v[i] for v in verts) for i in range(2)]
hi = [max(v[i] for v in verts) for i in range(2)]
with open(sys.argv[2], "w") as out:
    out.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
              "property float s\nproperty float t\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
              "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (nv, len(faces)))
    for x, y, z in verts:
        s, t = (x - lo[0]) / (hi[0] - lo[0]), (y - lo[1]) / (hi[1] - lo[1])
        rgb = (230, 120, 40) if (int(s * 8) + int(t * 8)) % 2 else (250, 240, 220)
        out.write("%r %r %r %.6f %.6f %d %d %d\n" % (x, y, z, s, t, *rgb))
    out.write("\n".join(faces) + "\n")
PY
$cli render "$tmp/bunny-textured.ply" -o "$out/bunny-textured-before.png" --view front --size 480x480
$cli smooth "$tmp/bunny-textured.ply" -o "$tmp/bunny-textured-smooth.ply" --flow median --iterations 20 --quiet
$cli render "$tmp/bunny-textured-smooth.ply" -o "$out/bunny-textured-after.png" --view front --size 480x480
# A region: the rabbit's head (a sphere, 8 mm falloff) smoothed by the default job, the rest kept.
region=(--region sphere:-49,-25,-1256,22 --falloff 8)
xz -dc "$real/rabbit.obj.xz" >"$tmp/rabbit.obj"
$cli render "$tmp/rabbit.obj" -o "$out/rabbit-region-before.png" --view front --size 480x480 --shading flat "${region[@]}"
$cli smooth "$tmp/rabbit.obj" -o "$tmp/rabbit-region.obj" --quiet "${region[@]}"
$cli render "$tmp/rabbit-region.obj" -o "$out/rabbit-region-after.png" --view front --size 480x480 --shading flat \
  "${region[@]}"
# A worn relief enhanced back: the bunny smoothed hard, then its detail below 6 mean edges sharpened.
$cli smooth "$meshes/stanford-bunny.ply" -o "$tmp/bunny-worn.ply" --flow laplacian --iterations 10 --quiet
$cli render "$tmp/bunny-worn.ply" -o "$out/bunny-worn.png" --view front --size 480x480
$cli enhance "$tmp/bunny-worn.ply" -o "$tmp/bunny-enhanced.ply" --gain 3 --detail 6h --quiet
$cli render "$tmp/bunny-enhanced.ply" -o "$out/bunny-enhanced.png" --view front --size 480x480
