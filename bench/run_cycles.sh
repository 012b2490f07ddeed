#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The preview held against a path tracer: the Bricks102 wall from ../shared, wetted by
# wet_material (water level LEVEL, default 0.75), drawn by the `preview` node and rendered by
# Blender Cycles (CPU) from the same maps, the same camera (fov 35, zoom 1, azimuth 20, each
# elevation in ELEVATIONS, default "50 20") and the same HDR (ENV, default venice_sunset_1k);
# then per zone (dry, moist, wet, immersed) the mean linear luminance of both pictures and their
# ratio preview / Cycles (bench/cycles_compare.py; docs/preview.md shows a run).
#   LAYERS   single (default): the one-surface maps, the water baked into them, on both sides;
#            two: the layered maps, the water a layer of its own in the preview and a refracting
#            surface in Cycles; "single two" for both
#   BRDF     preview (default): Cycles shades with the preview's model (Principled's GGX lobe
#            and Lambert diffuse weighted by 1 − E from the preview's own split-sum table), so
#            the ratios measure the preview's lighting (split sum, prefiltering, relief by
#            parallax, AO map); principled: Principled BSDF as it is (Disney diffuse, not
#            reduced by what the lobe reflects), to see how far the model itself is
#   SAMPLES  Cycles samples per pixel (default 128), SIZE the pictures' side (default 512; the
#            preview reads its lighting atlas at 512, smaller pictures blur it)
#   OUT      folder kept with the maps, both pictures and side_by_side_<layers>_<elevation>.png
#            (default: a temporary folder, removed)
# Needs Blender (scripts/install-deps.sh --bench: Debian's blender and python3-numpy). Cycles
# takes tens of seconds per 64 samples at 512² on 2 cores, more with the water layer; the host
# and its load are printed with the results.
# Usage: bench/run_cycles.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
level=${LEVEL:-0.75}
elevations=${ELEVATIONS:-50 20}
envname=${ENV:-venice_sunset_1k}
layers=${LAYERS:-single}
brdf=${BRDF:-preview}
samples=${SAMPLES:-128}
size=${SIZE:-512}
command -v blender >/dev/null || {
    echo "run_cycles.sh: blender not found (scripts/install-deps.sh --bench installs it)" >&2
    exit 1
}
[[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph >/dev/null
. "$root/bench/bricks.sh"
env=$root/../shared/env/$envname.hdr
[[ -f "$env" ]] || { echo "run_cycles.sh: $env: no such environment map" >&2; exit 1; }
if [[ -n "${OUT:-}" ]]; then
    out=$OUT
    mkdir -p "$out"
else
    out=$(mktemp -d)
    trap 'rm -rf "$out"' EXIT
fi
hs=$(python3 -c 'print(16 / 256)') # wet_material's height_scale 16, in tile widths
echo "host: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(nproc) cores; load average: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "$(blender --version 2>/dev/null | head -1), $samples samples, ${size}², $envname, water level $level, brdf $brdf"
for el in $elevations; do
    d=$out/el$el
    "$build/cli/wetgraph" render "$root/bench/cycles_scene.wetgraph" -o "$d" -q \
        --size "$size" \
        --input environment="$env" \
        "${bricks_inputs[@]}" \
        --set water_level="$level" --set elevation="$el"
    for l in $layers; do
        pv=$d/cycles_scene_preview.exr
        [[ $l == two ]] && pv=$d/cycles_scene_preview_two.exr
        start=$(date +%s)
        blender -b --factory-startup --python-exit-code 1 -P "$root/bench/cycles_scene.py" -- "$d" "$env" \
            "$d/cycles_$l.exr" elevation="$el" size="$size" samples="$samples" brdf="$brdf" \
            layers="$l" height_scale="$hs" >"$d/blender_$l.log" 2>&1 ||
            { echo "run_cycles.sh: Cycles failed, see $d/blender_$l.log" >&2; tail -5 "$d/blender_$l.log" >&2; exit 1; }
        echo "elevation $el, $l layer(s): Cycles $(($(date +%s) - start)) s"
        blender -b --factory-startup --python-exit-code 1 -P "$root/bench/cycles_compare.py" -- "$pv" \
            "$d/cycles_scene_zones.exr" "$d/cycles_$l.exr" "$el" 20 35 1 "$hs" \
            "$out/side_by_side_${l}_$el.png" 2>&1 |
            grep -v '^Blender \|^$\|^Blender quit\|^side by side' | sed 's/^/  /'
    done
done
[[ -n "${OUT:-}" ]] && echo "pictures: $out/side_by_side_*.png"
exit 0
