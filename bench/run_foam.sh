#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Shore foam at 1024² (graphs/foam.wetgraph on graphs/examples/shore.wetgraph), in one process:
#  1. 48 frames of the foam output: node time of the sequence (the sum of the nodes' own times
#     from --stats=json), the whole-process time with the PNG writes, and how many times the
#     shore's distance transform ran (once). Target: 48 frames in <= 5 s of node time on 2 cores.
#  2. FRAMES frames (default 60) with all four outputs (two PNGs, two float EXRs): whole process
#     per frame against node time per frame (target: at most 2x), the outputs' work during the
#     renders, how many files were encoded and how many copied (the EXRs, which do not depend
#     on $time, are encoded for the first frame only), peak resident memory, and what the engine held between frames (which must not
#     grow with the number of frames: also printed for a third of the frames).
# Results vary with the machine's load, which is printed.
#   bench/run_foam.sh [BUILD_DIR] [THREADS] [FRAMES]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
threads=${2:-2}
frames=${3:-60}
wg=$build/cli/wetgraph
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
"$wg" render "$root/graphs/examples/shore.wetgraph" --size 1024 -o "$tmp" -q
start=$(date +%s.%N)
"$wg" render "$root/graphs/foam.wetgraph" --input shore="$tmp/shore_land.png" --output foam \
    --frames 0:47 --fps 24 --threads "$threads" -o "$tmp/seq" -q --stats=json >"$tmp/stats.json"
end=$(date +%s.%N)
python3 - "$tmp/stats.json" "$start" "$end" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
wall = float(sys.argv[3]) - float(sys.argv[2])
sd = next(n for n in s["nodes"] if n["id"] == "sd")
node = sum(n["ms"] for n in s["nodes"])
print(f"frames {s['frames']}, node time {node / 1000:.2f} s "
      f"({node / s['frames']:.1f} ms a frame), whole process with PNG writes {wall:.2f} s")
print(f"shore distance transform computed {sd['computed']} time(s), reused {sd['reused']}")
print("target 48 frames <= 5 s (node time):", "met" if node <= 5000 else "NOT met")
PY
echo "CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores"
for n in $((frames / 3)) "$frames"; do
    rm -rf "$tmp/all"
    start=$(date +%s.%N)
    /usr/bin/time -f "%M" -o "$tmp/rss.txt" "$wg" render "$root/graphs/foam.wetgraph" \
        --input shore="$tmp/shore_land.png" --frames "0:$((n - 1))" --fps 24 \
        --threads "$threads" -o "$tmp/all" -q --stats=json >"$tmp/all.json"
    end=$(date +%s.%N)
    python3 - "$tmp/all.json" "$start" "$end" "$(tail -1 "$tmp/rss.txt")" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
wall = (float(sys.argv[3]) - float(sys.argv[2])) * 1e3
node = sum(n["ms"] for n in s["nodes"])
f = s["frames"]
print(f"{f} frames, all outputs: whole process {wall / f:.0f} ms a frame, node time "
      f"{node / f:.0f} ms a frame, ratio {wall / node:.2f} (target <= 2); output work "
      f"{s['output_ms'] / f:.0f} ms a frame during the renders; files "
      f"{s['files']['written']} encoded, {s['files']['copied']} copied; peak RSS "
      f"{int(sys.argv[4]) / 1024:.0f} MiB; held between frames {s['held_bytes'] / 2**20:.0f} MiB")
PY
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
