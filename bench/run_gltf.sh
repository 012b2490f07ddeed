#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The wet material as a glTF asset in Blender: graphs/wet_gltf.wetgraph renders the Bricks102
# wall from ../shared wet (water level LEVEL, default 0.7) as wet_gltf_wet.gltf; Blender imports
# it headless (bench/blender_gltf.py), checks that the Principled BSDF's base colour, metallic,
# roughness, normal, specular and clear-coat inputs are linked to the asset's textures, and
# renders it with Cycles under the Venice sunset to OUT (default docs/img/wet_gltf_blender.png).
# Needs Blender (scripts/install-deps.sh --bench).
# Usage: bench/run_gltf.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
level=${LEVEL:-0.7}
out=${OUT:-$root/docs/img/wet_gltf_blender.png}
command -v blender >/dev/null || { echo "run_gltf.sh: blender not found (scripts/install-deps.sh --bench)" >&2; exit 1; }
[[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph >/dev/null
mat=$root/../shared/materials/bricks102_stonewall_1k/Bricks102_1K-JPG
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/cli/wetgraph" render "$root/graphs/wet_gltf.wetgraph" -o "$tmp" -q --size 512 \
    --input basecolor="${mat}_Color.jpg" --input height="${mat}_Displacement.jpg" \
    --input normal="${mat}_NormalGL.jpg" --input roughness="${mat}_Roughness.jpg" \
    --input ao="${mat}_AmbientOcclusion.jpg" --set water_level="$level"
echo "$(blender --version 2>/dev/null | head -1); host: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), load average $(cut -d' ' -f1-3 /proc/loadavg)"
blender -b --factory-startup --python-exit-code 1 -P "$root/bench/blender_gltf.py" -- \
    "$tmp/wet_gltf_wet.gltf" "$root/../shared/env/venice_sunset_1k.hdr" "$out" 2>&1 |
    grep -v '^Blender \|^$\|^Blender quit\|^Fra:\|^Saved\|^Time:\|^Read\|^Info\|^ *$'
