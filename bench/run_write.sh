#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Writing the outputs: graphs/wet_material.wetgraph on the Bricks102 wall from ../shared at
# SIZE² (default 2048) with THREADS workers (default 2), its outputs (all PNG, 8- and 16-bit), against cv2.imwrite.
#  cold     a render into an empty folder: whole process wall time and its CPU time, render time
#           (total_ms of --stats=json: the nodes and, overlapping them on the same workers, the
#           outputs' hashing, encoding and flushing), output work (output_ms: those summed over
#           the workers), the tail after the render (write_ms: the renames), node compute (the
#           sum of the nodes' times) and peak resident memory
#  alone    the same render with nothing written, in a fresh engine as in a process
#           (build/bench/bench_wet's "first" render: total_ms), the render time the whole
#           process is held against
#  cv2      cv2.imwrite of the same images (read back from the files just written), one after
#           the other, zlib level 1 (IMWRITE_PNG_COMPRESSION=1, as OpenImageIO wrote them before)
#  rerender a --cache render after a change of one texturing parameter (dark_wet) into the
#           folder of the previous one: whole process wall time, outputs kept, its share of cold
#  files    the total size of the PNG files of the cold render, and of cv2's
#  encoder  the PNG encoder alone on those files, every compression mode, one thread, from
#           memory (build/bench/bench_png): MB/s of raw image data and the files' total size
# Best of RUNS (default 3) each; the cold renders and the renders alone alternate, so that both
# meet the host in the same states. Every render writes its PNGs with --png-compression
# PNG_COMPRESSION (fast, deflate or none; default: fast). Prints the CPU model and the load
# average: timing is noisy on a loaded machine. Needs python3-opencv (scripts/install-deps.sh
# --bench).
# Usage: [PNG_COMPRESSION=MODE] bench/run_write.sh [BUILD_DIR] [SIZE] [THREADS] [RUNS]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
size=${2:-2048}
threads=${3:-2}
runs=${4:-3}
compression=${PNG_COMPRESSION:-fast}
[[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph bench/bench_wet bench/bench_png >/dev/null
py=${PYTHON:-/usr/bin/python3}  # the system python, which python3-opencv installs into
. "$root/bench/bricks.sh"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
inputs=("${bricks_inputs[@]}" --set water_level=0.65 --png-compression "$compression")
render() { # out-folder, extra args...
    local out=$1
    shift
    "$build/cli/wetgraph" render "$root/graphs/wet_material.wetgraph" -o "$out" -q \
        --size "$size" --threads "$threads" --stats=json \
        "${inputs[@]}" "$@"
}
# "wall_ms total_ms write_ms kept written output_ms node_ms cpu_ms rss_mib" of one render
timed() {
    local t0 t1
    t0=$(date +%s%N)
    /usr/bin/time -f "%U %S %M" -o "$tmp/time.txt" "$build/cli/wetgraph" render \
        "$root/graphs/wet_material.wetgraph" -o "$1" -q --size "$size" --threads "$threads" \
        --stats=json "${inputs[@]}" "${@:2}" >"$tmp/stats.json"
    t1=$(date +%s%N)
    python3 - "$tmp/stats.json" $(((t1 - t0) / 1000)) "$tmp/time.txt" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
user, system, rss = open(sys.argv[3]).read().split()[-3:]
kept = sum(o["file"] == "kept" for o in d.get("outputs", []))
print("%.0f %.0f %.0f %d %d %.0f %.0f %.0f %.0f" % (int(sys.argv[2]) / 1e3, d["total_ms"],
      d.get("write_ms", 0), kept, len(d.get("outputs", [])) - kept, d.get("output_ms", 0),
      sum(n["ms"] for n in d["nodes"]), (float(user) + float(system)) * 1e3, int(rss) / 1024))
PY
}
echo "host: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores;" \
    "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "wet_material ${size}², $threads threads, its PNG outputs (--png-compression $compression)," \
    "best of $runs"
# the cold render and the render alone in turn, so that both see the host in the same states
best_wall=0 alone=0
for i in $(seq "$runs"); do
    rm -rf "$tmp/cold"
    read -r wall total write _ written out nodes cpu rss < <(timed "$tmp/cold")
    if ((best_wall == 0 || wall < best_wall)); then
        best_wall=$wall best_total=$total best_write=$write n=$written best_out=$out
        best_nodes=$nodes best_cpu=$cpu best_rss=$rss
    fi
    a=$(cd "$root" && "$build/bench/bench_wet" --size "$size" --threads "$threads" --reps 1 |
        awk '$1 == "first" { printf "%.0f", $5 }')
    if ((alone == 0 || a < alone)); then alone=$a; fi
done
echo "cold:     whole process $best_wall ms (CPU $best_cpu ms, peak RSS $best_rss MiB), render" \
    "with the outputs $best_total ms, node compute $best_nodes ms, output work $best_out ms" \
    "(during the render), $best_write ms after it ($n files)"
echo "alone:    the render writing nothing $alone ms; whole process / render alone" \
    "$(python3 -c "print('%.2f' % ($best_wall / $alone))")"
read -r cv2_ms cv2_bytes < <("$py" - "$tmp/cold" "$runs" <<'PY'
import cv2, glob, os, sys, time
imgs = [cv2.imread(f, cv2.IMREAD_UNCHANGED) for f in sorted(glob.glob(sys.argv[1] + "/*.png"))]
out = os.path.join(sys.argv[1], "..", "cv2.png")
best = None
for _ in range(int(sys.argv[2])):
    t = time.perf_counter()
    for im in imgs:
        cv2.imwrite(out, im, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    t = (time.perf_counter() - t) * 1e3
    best = t if best is None else min(best, t)
size = 0
for im in imgs:
    cv2.imwrite(out, im, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    size += os.path.getsize(out)
print("%.0f %d" % (best, size))
PY
)
echo "cv2:      cv2.imwrite of the same $n images $cv2_ms ms; output work (summed over the" \
    "workers) / cv2 $(python3 -c "print('%.2f' % ($best_out / $cv2_ms))")"
bytes=$(cat "$tmp/cold"/*.png | wc -c)
echo "files:    the $n PNG files $(python3 -c "print('%.1f' % ($bytes / 1e6))") MB, cv2's" \
    "$(python3 -c "print('%.1f' % ($cv2_bytes / 1e6))") MB; / cv2" \
    "$(python3 -c "print('%.2f' % ($bytes / $cv2_bytes))")"
echo "encoder:  the PNG encoder alone on the same files, each mode (build/bench/bench_png)"
"$build/bench/bench_png" --reps "$runs" "$tmp/cold"/*.png | sed 's/^/          /'
rm -rf "$tmp/warm"
render "$tmp/warm" --cache "$tmp/cache" >/dev/null
best=0
for i in $(seq "$runs"); do
    read -r wall total write kept written _ < <(timed "$tmp/warm" --cache "$tmp/cache" --set "dark_wet=0.9$i")
    if ((best == 0 || wall < best)); then bw=$write bk=$kept bn=$written best=$wall; fi
done
echo "rerender: whole process $best ms (dark_wet changed, --cache): $bn written, $bk kept," \
    "writing $bw ms; $(python3 -c "print('%.0f' % (100 * $best / $best_wall))") % of cold"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
