#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Render the pictures of docs/preview.md into docs/img/: the Bricks102 wall from ../shared dry
# (top), wet up to water level 0.6 (middle) and 0.75 (bottom), and the two other shared
# materials (PavingStones130, the worn wooden boards) dry and wet side by side, through
# graphs/wet_preview.wetgraph, under each of the two environment maps of ../shared/env. Each picture is rendered at 512² (the size of
# the prefiltered environment atlas, so the preview reads it as it is) and cropped to the tile;
# crops and stacking with oiiotool (openimageio-tools, scripts/install-deps.sh --docs).
# Usage: scripts/preview_pictures.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=${1:-build}
scripts/install-deps.sh --docs
[[ -f "$build/build.ninja" ]] || meson setup "$build" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph >/dev/null
wg="$root/$build/cli/wetgraph"
[[ -x "$wg" ]] || wg="$build/cli/wetgraph"
img=docs/img
mkdir -p "$img"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
m=../shared/materials/bricks102_stonewall_1k/Bricks102_1K-JPG
# name, environment file, rotation of the environment (180: the sunset's bright sky behind
# the tile, reflected towards the camera by the water)
for spec in "venice:venice_sunset_1k:180" "potsdamer:potsdamer_platz_1k:180"; do
    IFS=: read -r name env rot <<<"$spec"
    for level in 0.6 0.75; do
        "$wg" render graphs/wet_preview.wetgraph -o "$tmp/$name$level" -q --size 512 \
            --input environment=../shared/env/$env.hdr \
            --input basecolor=${m}_Color.jpg --input height=${m}_Displacement.jpg \
            --input normal=${m}_NormalGL.jpg --input roughness=${m}_Roughness.jpg \
            --input ao=${m}_AmbientOcclusion.jpg \
            --set water_level=$level --set elevation=25 --set azimuth=15 --set zoom=1.3 \
            --set env_rotation=$rot
    done
    oiiotool "$tmp/${name}0.6/wet_preview_preview_dry.png" --cut 512x240+0+210 \
        "$tmp/${name}0.6/wet_preview_preview_wet.png" --cut 512x240+0+210 \
        "$tmp/${name}0.75/wet_preview_preview_wet.png" --cut 512x240+0+210 \
        --mosaic 1x3 -o "$img/preview_$name.png"
done

# the other two materials under the overcast sky, dry (left) and wet (right), shrunk to 256 wide
p=../shared/materials/pavingstones130_1k/PavingStones130_1K
w=../shared/materials/wood_cabinet_worn_long_1k/wood_cabinet_worn_long
"$wg" render graphs/wet_preview.wetgraph -o "$tmp/paving" -q --size 512 \
    --input environment=../shared/env/potsdamer_platz_1k.hdr \
    --input basecolor=${p}_Color.jpg --input height=${p}_Displacement.jpg \
    --input normal=${p}_NormalGL.jpg --input roughness=${p}_Roughness.jpg \
    --input ao=${p}_AmbientOcclusion.jpg \
    --set water_level=0.8 --set elevation=25 --set azimuth=15 --set zoom=1.3 --set env_rotation=180
"$wg" render graphs/wet_preview.wetgraph -o "$tmp/wood" -q --size 512 \
    --input environment=../shared/env/potsdamer_platz_1k.hdr \
    --input basecolor=${w}_diff_1k.jpg --input height=${w}_disp_1k.png \
    --input normal=${w}_nor_gl_1k.png --input roughness=${w}_rough_1k.png \
    --set water_level=0.7 --set elevation=25 --set azimuth=15 --set zoom=1.3 --set env_rotation=180
oiiotool "$tmp/paving/wet_preview_preview_dry.png" --cut 512x240+0+210 --resize 256x120 \
    "$tmp/paving/wet_preview_preview_wet.png" --cut 512x240+0+210 --resize 256x120 \
    "$tmp/wood/wet_preview_preview_dry.png" --cut 512x240+0+210 --resize 256x120 \
    "$tmp/wood/wet_preview_preview_wet.png" --cut 512x240+0+210 --resize 256x120 \
    --mosaic 2x2 -o "$img/preview_materials.png"
