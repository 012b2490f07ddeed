#!/bin/sh
# SPDX-License-Identifier: MIT
# Start-up and image reading, in one run.
# 1. Whole-process wall time (median of RUNS, fork to exit) of `wetgraph nodes`, `wetgraph
#    check` of a 30-node graph, and a render whose input and output are EXR (64²), beside a
#    trivial C program (`int main(void) { return 0; }`): what the dynamic linker and the
#    library's set-up cost. None of these loads OpenImageIO.
# 2. The `image` node's own time (from --stats, median of RUNS renders) reading a 1024² JPEG
#    (../shared/materials, sRGB), a 2048² 16-bit RGB PNG and a 2048² float RGB EXR (both made
#    here by wetgraph from noise), beside OpenImageIO reading the same file as float: its
#    ImageInput in bench/peer_oiio_read.cpp (median of RUNS, after an untimed first read) and
#    oiiotool's own --runstats total for `-i:now=1:type=float FILE` (OpenImageIO's timer, 10 ms
#    resolution; the process start-up excluded).
# 3. The five JPEGs of the wet material's wall as `image` nodes, at their own size and
#    resampled to 2048², in a new process (--stats: the output is new memory) and pooled
#    (bench/bench_read: the output from the engine's pool, compute alone), beside cv2.imread +
#    conversion to float (+ cv2.resize) of the same files in a warm Python loop, in the same run
#    (python3-opencv); then the host's CPU and load average.
# Builds BUILD_DIR first (default: build, set up as a release build if missing); needs oiiotool
# and the OpenImageIO headers (scripts/install-deps.sh --bench). Timing is noisy on a loaded
# machine: run it on an idle one.
# Usage: bench/run_io.sh [BUILD_DIR] [RUNS]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
runs=${2:-11}
[ -f "$build/build.ninja" ] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" >/dev/null
command -v oiiotool >/dev/null || { echo "run_io.sh: needs oiiotool (scripts/install-deps.sh --bench)" >&2; exit 1; }
wg=$build/cli/wetgraph
jpeg=$root/../shared/materials/pavingstones130_1k/PavingStones130_1K_Color.jpg
[ -f "$jpeg" ] || { echo "run_io.sh: missing $jpeg" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# the tools: a trivial program, a timer that forks and execs, the OpenImageIO peer
printf 'int main(void) { return 0; }\n' >"$tmp/true.c"
cc -O2 "$tmp/true.c" -o "$tmp/true"
cat >"$tmp/runtime.c" <<'EOF'
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}
int main(int argc, char **argv)
{
    int n = atoi(argv[1]);
    double t[1000];
    for (int i = 0; i < n && i < 1000; i++) {
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        pid_t p = fork();
        if (p == 0) {
            int fd = open("/dev/null", O_WRONLY);
            dup2(fd, 1);
            dup2(fd, 2);
            execv(argv[2], argv + 2);
            _exit(127);
        }
        int st;
        waitpid(p, &st, 0);
        clock_gettime(CLOCK_MONOTONIC, &b);
        if (!WIFEXITED(st) || WEXITSTATUS(st)) {
            fprintf(stderr, "runtime: %s failed\n", argv[2]);
            return 1;
        }
        t[i] = (b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) / 1e6;
    }
    qsort(t, (size_t)n, sizeof t[0], cmp);
    printf("%.1f\n", t[n / 2]);
    return 0;
}
EOF
cc -O2 "$tmp/runtime.c" -o "$tmp/runtime"
c++ -O2 -std=c++17 "$root/bench/peer_oiio_read.cpp" -o "$tmp/peer_oiio_read" \
    $(pkg-config --cflags --libs OpenImageIO)

# the 30-node graph: noise, then 28 adjustments and blurs in a chain, then a blend
{
    echo '<wetgraph version="1" size="256">'
    echo '  <input name="height" type="gray" default="0.5"/>'
    echo '  <node id="n0" type="noise" scale="4"/>'
    i=1
    while [ $i -le 28 ]; do
        case $((i % 4)) in
        0) t='invert' ;;
        1) t='blur sigma="2"' ;;
        2) t='levels in_low="0.1"' ;;
        3) t='clamp' ;;
        esac
        echo "  <node id=\"n$i\" type=\"${t%% *}\"$(echo "$t" | sed -n 's/^[a-z]*\( .*\)/\1/p')>"
        echo "    <in name=\"source\" from=\"n$((i - 1))\"/>"
        echo "  </node>"
        i=$((i + 1))
    done
    echo '  <node id="n29" type="blend" mode="multiply">'
    echo '    <in name="foreground" from="n28"/><in name="background" from="$height"/>'
    echo '  </node>'
    echo '  <output name="out" from="n29" format="exr"/>'
    echo '</wetgraph>'
} >"$tmp/g30.wetgraph"
"$wg" check "$tmp/g30.wetgraph" >/dev/null

# the files read
cat >"$tmp/gen.wetgraph" <<'EOF'
<wetgraph version="1" size="2048">
  <node id="a" type="noise" scale="64" octaves="6"/>
  <node id="b" type="noise" scale="16" octaves="3" seed="5"/>
  <node id="rgb" type="merge"><in name="r" from="a"/><in name="g" from="b"/><in name="b" from="a"/></node>
  <output name="png16" from="rgb" format="png16"/>
  <output name="exr32" from="rgb" format="exr32"/>
</wetgraph>
EOF
"$wg" render "$tmp/gen.wetgraph" -q -o "$tmp" --size 64 --output exr32
mv "$tmp/gen_exr32.exr" "$tmp/small.exr"
"$wg" render "$tmp/gen.wetgraph" -q -o "$tmp"
cat >"$tmp/exr_only.wetgraph" <<EOF
<wetgraph version="1" size="64">
  <node id="img" type="image" path="small.exr"/>
  <node id="inv" type="invert"><in name="source" from="img"/></node>
  <output name="out" from="inv" format="exr"/>
</wetgraph>
EOF

echo "Whole-process time, median of $runs (ms):"
echo
printf '| %-48s | %8s |\n' "command" "ms"
printf '|%s|%s|\n' "--------------------------------------------------" "----------"
row() { printf '| %-48s | %8s |\n' "$1" "$2"; }
row "true (a one-line C program)" "$("$tmp/runtime" "$runs" "$tmp/true")"
row "wetgraph --help" "$("$tmp/runtime" "$runs" "$wg" --help)"
row "wetgraph nodes" "$("$tmp/runtime" "$runs" "$wg" nodes)"
row "wetgraph check (30 nodes)" "$("$tmp/runtime" "$runs" "$wg" check "$tmp/g30.wetgraph")"
row "wetgraph render, EXR in and out (64², 2 nodes)" \
    "$("$tmp/runtime" "$runs" "$wg" render "$tmp/exr_only.wetgraph" -q -o "$tmp/out")"

# the image node's time: column 3 of its --stats line, median of the runs
node_ms() { # FILE SIZE COLORSPACE
    printf '<wetgraph version="1" size="%s">\n  <node id="img" type="image" path="%s" colorspace="%s"/>\n  <output name="o" from="img" format="exr"/>\n</wetgraph>\n' \
        "$2" "$1" "$3" >"$tmp/read.wetgraph"
    i=0
    while [ $i -lt "$runs" ]; do
        "$wg" render "$tmp/read.wetgraph" -o "$tmp/out" --stats 2>&1 | awk '$1 == "img" { print $3 }'
        i=$((i + 1))
    done | sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'
}
oiiotool_ms() {
    i=0
    while [ $i -lt "$runs" ]; do
        oiiotool --runstats -i:now=1:type=float "$1" 2>&1 | awk '/Total time/ { sub("s", "", $3); print $3 * 1000 }'
        i=$((i + 1))
    done | sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'
}
echo
echo "Reading an image file, median of $runs (ms):"
echo
printf '| %-28s | %10s | %16s | %9s | %13s |\n' "file" "image node" "OIIO ImageInput" "oiiotool" "node / OIIO"
printf '|%s|%s|%s|%s|%s|\n' "------------------------------" "------------" "------------------" "-----------" "---------------"
for spec in "$jpeg:1024:srgb:1024² JPEG (sRGB)" "$tmp/gen_png16.png:2048:linear:2048² 16-bit RGB PNG" \
    "$tmp/gen_exr32.exr:2048:linear:2048² float RGB EXR"; do
    file=${spec%%:*}
    rest=${spec#*:}
    size=${rest%%:*}
    rest=${rest#*:}
    cs=${rest%%:*}
    name=${rest#*:}
    ours=$(node_ms "$file" "$size" "$cs")
    peer=$("$tmp/peer_oiio_read" "$file" "$runs")
    tool=$(oiiotool_ms "$file")
    printf '| %-28s | %10s | %16s | %9s | %13s |\n' "$name" "$ours" "$peer" "$tool" \
        "$(awk -v a="$ours" -v b="$peer" 'BEGIN { printf "%.2f", a / b }')"
done

# The five JPEGs of the wet material's wall, as `image` nodes at the file's size (1024x512) and
# resampled to 2048² (the wet benches' size), beside cv2.imread of the same file (unchanged:
# gray stays one channel) and its conversion to float, and for 2048² also cv2.resize with
# INTER_LINEAR, in the same run (median of RUNS after a first untimed read; one OpenCV thread,
# the image node decodes on one thread and resamples on the render's 2). The colour map is read
# sRGB-decoded by the node (a table lookup per value) and as plain codes / 255 by the peer.
py=${PYTHON:-/usr/bin/python3} # the system python, which python3-opencv installs into
mat=$root/../shared/materials/bricks102_stonewall_1k
if "$py" -c 'import cv2' 2>/dev/null && [ -d "$mat" ]; then
    cv2_ms() { # FILE SIZE (0: the file's own)
        "$py" - "$1" "$2" "$runs" <<'PY'
import sys, time
import cv2
import numpy as np
cv2.setNumThreads(1)
path, size, runs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
def once():
    t = time.perf_counter()
    a = cv2.imread(path, cv2.IMREAD_UNCHANGED).astype(np.float32) * np.float32(1 / 255)
    if size:
        a = cv2.resize(a, (size, size), interpolation=cv2.INTER_LINEAR)
    return (time.perf_counter() - t) * 1e3
once()
t = sorted(once() for _ in range(runs))
a = cv2.imread(path, cv2.IMREAD_UNCHANGED)
print("%.2f %dx%d" % (t[len(t) // 2], a.shape[1], a.shape[0]))
PY
    }
    ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }
    sum() { awk -v a="$1" -v b="$2" 'BEGIN { print a + b }'; }
    echo
    echo "The wet material's JPEGs as image nodes against cv2.imread + float (+ cv2.resize), median of $runs (ms)."
    echo "node: a new process (--stats), its output new memory; pooled: bench_read, the node in one"
    echo "engine whose output comes from its buffer pool, as the Python loop reuses its heap."
    echo
    printf '| %-17s | %9s | %9s | %9s | %8s | %11s | %9s | %9s | %9s | %8s | %11s |\n' "file" \
        "node file" "pooled" "cv2 file" "node/cv2" "pooled/cv2" "node 2K" "pooled 2K" "cv2 2K" \
        "node/cv2" "pooled/cv2"
    printf '|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|\n' "-------------------" "-----------" "-----------" \
        "-----------" "----------" "-------------" "-----------" "-----------" "-----------" \
        "----------" "-------------"
    s_n1=0 s_p1=0 s_c1=0 s_n2=0 s_p2=0 s_c2=0
    for map in Color AmbientOcclusion Displacement NormalGL Roughness; do
        file=$mat/Bricks102_1K-JPG_$map.jpg
        cs=linear
        [ $map = Color ] && cs=srgb
        c1=$(cv2_ms "$file" 0)
        wh=${c1#* }
        c1=${c1% *}
        n1=$(node_ms "$file" "$wh" "$cs")
        p1=$("$build/bench/bench_read" --reps "$runs" "$file" "$cs" "$wh")
        n2=$(node_ms "$file" 2048 "$cs")
        p2=$("$build/bench/bench_read" --reps "$runs" "$file" "$cs" 2048x2048)
        c2=$(cv2_ms "$file" 2048)
        c2=${c2% *}
        printf '| %-17s | %9s | %9s | %9s | %8s | %11s | %9s | %9s | %9s | %8s | %11s |\n' "$map" \
            "$n1" "$p1" "$c1" "$(ratio "$n1" "$c1")" "$(ratio "$p1" "$c1")" "$n2" "$p2" "$c2" \
            "$(ratio "$n2" "$c2")" "$(ratio "$p2" "$c2")"
        s_n1=$(sum "$s_n1" "$n1") s_p1=$(sum "$s_p1" "$p1") s_c1=$(sum "$s_c1" "$c1")
        s_n2=$(sum "$s_n2" "$n2") s_p2=$(sum "$s_p2" "$p2") s_c2=$(sum "$s_c2" "$c2")
    done
    printf '| %-17s | %9s | %9s | %9s | %8s | %11s | %9s | %9s | %9s | %8s | %11s |\n' "all five" \
        "$s_n1" "$s_p1" "$s_c1" "$(ratio "$s_n1" "$s_c1")" "$(ratio "$s_p1" "$s_c1")" "$s_n2" \
        "$s_p2" "$s_c2" "$(ratio "$s_n2" "$s_c2")" "$(ratio "$s_p2" "$s_c2")"
else
    echo
    echo "(no python3-opencv or no $mat: the cv2 comparison is left out)"
fi
echo
echo "(host: $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores; load average: $(cut -d' ' -f1-3 /proc/loadavg))"
