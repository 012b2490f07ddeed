#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Speed of the wet-material pipeline: graphs/wet_material.wetgraph on the Bricks102 wall from
# ../shared at SIZE² (default 2048) with THREADS workers (default 2), all outputs.
#  cold   node time of a render without cache: the sum of the nodes' own times from
#         --stats=json, image loading (the `image` nodes that read the input files) excluded;
#         best of RUNS renders (default 3)
#  warm   a render with --cache into a fresh folder, then RUNS renders each with a new value
#         of one texturing parameter (dark_wet): only the texturing nodes that depend on it run
#         again. Best node time, and its share of the best cold render.
#  floor  bench_wet at SIZE² and (2·SIZE)²: node time of the first render in a process (new
#         memory, touched for the first time: what `wetgraph render` pays) and of later renders
#         whose buffers come from the pool (compute alone), each in copies of a SIZE² float
#         plane timed in the same run (memcpy: two planes that may stay in the last-level
#         cache, and planes copied in turn from memory), and the growth from SIZE² to (2·SIZE)².
# Builds wetgraph in BUILD_DIR (default build) first. Timing is noisy on a loaded machine: the
# load average is printed with the results; run it on an idle machine for the real numbers.
# Usage: bench/run_wet.sh [BUILD_DIR] [SIZE] [THREADS] [RUNS]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
size=${2:-2048}
threads=${3:-2}
runs=${4:-3}
[[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph bench/bench_wet >/dev/null
. "$root/bench/bricks.sh"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# the output folder: a fresh one for the cache fill, since outputs whose files are current
# (their keys beside them) are kept without computing them
out=$tmp/out
render() {
    "$build/cli/wetgraph" render "$root/graphs/wet_material.wetgraph" -o "$out" -q \
        --size "$size" --threads "$threads" --stats=json \
        "${bricks_inputs[@]}" \
        --set water_level=0.65 "$@"
}
# node time (ms) of a --stats=json report, image loading excluded; then the computed count
node_ms() {
    python3 -c 'import json, sys
r = json.load(sys.stdin)
ms = sum(n["ms"] for n in r["nodes"] if n["type"] != "image")
print("%.1f %d" % (ms, r["evaluated"]))'
}
echo "wet_material, ${size}x${size}, $threads threads; load average: $(cut -d' ' -f1-3 /proc/loadavg)"
best=
for ((i = 0; i < runs; i++)); do
    read -r ms n < <(render | node_ms)
    echo "  cold run $((i + 1)): $ms ms node time ($n nodes)"
    if [[ -z "$best" ]] || python3 -c "import sys; sys.exit(not $ms < $best)"; then best=$ms; fi
done
out=$tmp/out_cached
read -r fill nf < <(render --cache "$tmp/cache" | node_ms)
echo "cold (best of $runs): $best ms node time; cache fill: $fill ms ($nf nodes)"
warm=
for ((i = 0; i < runs; i++)); do
    # a new value each time, so that the nodes depending on it miss the cache
    read -r ms nw < <(render --cache "$tmp/cache" --set dark_wet=0.9$i | node_ms)
    echo "  after changing dark_wet, run $((i + 1)): $ms ms ($nw nodes computed)"
    if [[ -z "$warm" ]] || python3 -c "import sys; sys.exit(not $ms < $warm)"; then warm=$ms; fi
done
echo "after changing dark_wet (best of $runs): $warm ms," \
     "$(python3 -c "print('%.0f' % (100 * $warm / $best))") % of the cold render"

# the memory floor: bench_wet's first and pooled renders, and memcpy in the same process
echo "host: $(lscpu | sed -n 's/^Model name: *//p'); $(uptime)"
small=$tmp/floor_small.txt large=$tmp/floor_large.txt
(cd "$root" && "$build/bench/bench_wet" --size "$size" --threads "$threads" --reps "$runs") >"$small"
(cd "$root" && "$build/bench/bench_wet" --size $((2 * size)) --threads "$threads" --reps "$runs") >"$large"
python3 - "$small" "$large" "$size" <<'PY'
import re, sys
def read(path):
    t = open(path).read()
    rows = {l.split("\t")[0]: l.split("\t") for l in t.splitlines() if l.startswith(("first\t", "pooled\t"))}
    copy = float(re.search(r"float plane: ([0-9.]+) ms", t).group(1))
    mem = float(re.search(r"from memory \(planes of ([0-9]+) MiB.*?\): ([0-9.]+) ms", t).group(2))
    hosts = re.findall(r"^# host.*$", t, re.M)
    return float(rows["first"][3]), float(rows["pooled"][3]), copy, mem, hosts
s, l, n = read(sys.argv[1]), read(sys.argv[2]), int(sys.argv[3])
for (first, pooled, copy, mem, hosts), size in ((s, n), (l, 2 * n)):
    print("%d²: node time first render %.0f ms, pooled %.0f ms, first touch %.0f ms; a copy of a "
          "%d² plane %.4f ms in cache, %.4f ms from memory: pooled %.0f / %.0f copies" % (size,
          first, pooled, first - pooled, size, copy, mem, pooled / copy, pooled / mem))
    for h in hosts: print("  " + h[2:])
print("%d² over %d²: first render %.2fx, pooled %.2fx (target at most 4.5x)" % (2 * n, n,
      l[0] / s[0], l[1] / s[1]))
print("%d² pooled node time in copies of a %d² plane (target at most 200): %.0f in cache, %.0f "
      "from memory; first render %.0f / %.0f" % (n, n, s[1] / s[2], s[1] / s[3], s[0] / s[2],
      s[0] / s[3]))
PY
