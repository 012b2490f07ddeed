#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Speed and error of the material preview (docs/preview.md).
#  speed  graphs/wet_preview.wetgraph on the Bricks102 wall from ../shared, water level 0.6,
#         Venice sunset environment, the wet picture at SIZE² (default 1024) with THREADS workers
#         (default 2): the `preview` node's own time from --stats=json (the environment is
#         prefiltered by its own node, env_prefilter, whose time is printed apart), best of
#         RUNS renders (default 3); then the dry picture, re-rendered with --cache and a new
#         camera azimuth each run, so that only the preview runs again.
#  error  bench/preview_reference (a Monte-Carlo reference of the same BRDF against the full
#         environment) on both environment maps, 4096 samples per pixel.
# Builds in BUILD_DIR (default build) first. Timing is noisy on a loaded machine: the load
# average is printed with the results.
# Usage: bench/run_preview.sh [BUILD_DIR] [SIZE] [THREADS] [RUNS]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
size=${2:-1024}
threads=${3:-2}
runs=${4:-3}
[[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph bench/preview_reference >/dev/null
. "$root/bench/bricks.sh"
env=$root/../shared/env
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
render() {
    "$build/cli/wetgraph" render "$root/graphs/wet_preview.wetgraph" -o "$tmp/out" -q \
        --size "$size" --threads "$threads" --stats=json \
        --input environment="$env/venice_sunset_1k.hdr" \
        "${bricks_inputs[@]}" \
        --set water_level=0.6 "$@"
}
# times (ms) of the preview nodes and of env_prefilter in a --stats=json report
times() {
    python3 -c 'import json, sys
r = json.load(sys.stdin)
pv = sum(n["ms"] for n in r["nodes"] if n["type"] == "preview")
env = sum(n["ms"] for n in r["nodes"] if n["type"] == "env_prefilter")
print("%.1f %.1f" % (pv, env))'
}
echo "preview, ${size}x${size}, $threads threads; load average: $(cut -d' ' -f1-3 /proc/loadavg)"
best=
for ((i = 0; i < runs; i++)); do
    read -r ms envms < <(render --output preview_wet | times)
    echo "  wet picture, run $((i + 1)): preview $ms ms (env_prefilter $envms ms)"
    if [[ -z "$best" ]] || python3 -c "import sys; sys.exit(not $ms < $best)"; then best=$ms; fi
done
echo "wet preview node (best of $runs): $best ms"
render --output preview_dry --cache "$tmp/cache" >/dev/null
dry=
for ((i = 0; i < runs; i++)); do
    read -r ms envms < <(render --output preview_dry --cache "$tmp/cache" --set azimuth=3$i | times)
    echo "  dry picture, new azimuth, run $((i + 1)): preview $ms ms (env_prefilter $envms ms)"
    if [[ -z "$dry" ]] || python3 -c "import sys; sys.exit(not $ms < $dry)"; then dry=$ms; fi
done
echo "dry preview node after a camera change (best of $runs): $dry ms"
for e in venice_sunset_1k potsdamer_platz_1k; do
    echo "error against the Monte-Carlo reference, $e:"
    "$build/bench/preview_reference" "$env/$e.hdr" 512 4096 | sed 's/^/  /'
done
