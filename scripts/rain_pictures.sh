#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Renders the pictures of docs/wet.md's "Rain ripples" into docs/img/ (needs a build and
# oiiotool: scripts/install-deps.sh --docs): a contact sheet of the rings on flat water over a
# 1.5-second loop, and the Bricks102 wall in the rain at water level 0.75 (the one-surface
# normal and the water layer's normal at one moment, a crop).
#   scripts/rain_pictures.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
wg=${1:-$root/build}/cli/wetgraph
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# 12 frames of a 1.5-second loop at 8 fps, 256 wide (large drops, steep rings), on a 4x3 grid
"$wg" render "$root/graphs/rain_ripples.wetgraph" --size 256 --set rain=0.6 --set drop_size=24 --set strength=1.5 \
    --set loop_seconds=1.5 --set ripple_seconds=0.75 --output ripplenormal --frames 0:11 \
    --fps 8 -o "$tmp/seq" --contact-sheet "$root/docs/img/rain_sheet.png" -q
sh=$root/../shared/materials/bricks102_stonewall_1k
"$wg" render "$root/graphs/wet_rain.wetgraph" -o "$tmp/wall" -q --time 0.4 \
    --input basecolor=$sh/Bricks102_1K-JPG_Color.jpg \
    --input height=$sh/Bricks102_1K-JPG_Displacement.jpg \
    --input normal=$sh/Bricks102_1K-JPG_NormalGL.jpg \
    --set water_level=0.75 --set rain=0.8 --output normal --output waternormal
oiiotool "$tmp/wall/wet_rain_normal.png" --cut 400x300+300+100 \
    "$tmp/wall/wet_rain_waternormal.png" --cut 400x300+300+100 --mosaic 2x1 \
    -o "$root/docs/img/rain_wall.png"
echo "wrote docs/img/rain_sheet.png docs/img/rain_wall.png"
