#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# The 3D view of `watch --serve` while it moves: the wet material on the PavingStones130 maps
# from ../shared at SIZE² (default 1024), lit by potsdamer_platz_1k.hdr, in headless chromium
# with software WebGL2 (SwiftShader: no GPU), window 1200 x 900. For each shape (plane, sphere,
# grid) a drag of 6 s, the mouse moving every 16 ms (bench/view3d_drag.js, run by
# tests/cli/page_driver.js), with the page's frame budget (50 ms a picture: moving pictures drawn
# at a lower resolution) and with ?frame_ms=0 (always full resolution); prints the pictures a
# second during the drag, the smallest scale drawn while moving, and the cost of a still
# full-resolution picture. RUNS (default 2) drags each, the best kept. Then the foam graph's
# page (graphs/foam.wetgraph at SIZE / 2 on a made-up shore): the pictures a second of foam.frag
# playing in the page (bench/foamview_play.js). Prints the CPU model and
# the load average: SwiftShader runs on the CPU, so the figures are this host's, not a GPU's.
# Needs chromium and node (scripts/install-deps.sh installs both).
# Usage: bench/run_view3d.sh [BUILD_DIR] [SIZE] [RUNS]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
size=${2:-1024}
runs=${3:-2}
[[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph >/dev/null
m=$root/../shared/materials/pavingstones130_1k/PavingStones130_1K_
tmp=$(mktemp -d)
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
"$build/cli/wetgraph" watch "$root/graphs/wet_material.wetgraph" -o "$tmp/out" --size "$size" \
    --input basecolor="${m}Color.jpg" --input height="${m}Displacement.jpg" \
    --input normal="${m}NormalGL.jpg" --input roughness="${m}Roughness.jpg" \
    --input ao="${m}AmbientOcclusion.jpg" --env "$root/../shared/env/potsdamer_platz_1k.hdr" \
    --serve "$port" >"$tmp/watch.log" 2>&1 &
watcher=$!
trap 'kill $watcher 2>/dev/null; wait $watcher 2>/dev/null; rm -rf "$tmp"' EXIT
until grep -q "watch: waiting" "$tmp/watch.log"; do
    kill -0 $watcher 2>/dev/null || { cat "$tmp/watch.log"; exit 1; }
    sleep 0.2
done
echo "host: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores;" \
    "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "3D view on SwiftShader, wet_material ${size}², best of $runs drags of 6 s"
printf '%-7s %-18s %9s %12s %12s %14s\n' shape budget canvas "pictures/s" "least scale" "still picture"
for shape in plane sphere grid; do
    for budget in 50 0; do
        best=
        for ((i = 0; i < runs; i++)); do
            out=$(node "$root/tests/cli/page_driver.js" \
                "http://127.0.0.1:$port/?events=0&split=0.35&shape=$shape&frame_ms=$budget" \
                "$root/bench/view3d_drag.js" "$tmp/profile")
            fps=$(python3 -c 'import json, sys; print(json.loads(sys.argv[1])[4])' "$out")
            if [[ -z $best ]] || python3 -c 'import sys; sys.exit(not float(sys.argv[1]) > float(sys.argv[2]))' "$fps" "$(cut -d' ' -f1 <<<"$best")"; then
                best="$fps $out"
            fi
        done
        python3 - "$shape" "$budget" "${best#* }" <<'PY'
import json, sys
shape, budget, r = sys.argv[1], int(sys.argv[2]), json.loads(sys.argv[3])
w, h, n, ms, fps, least, settled, cost = r
label = "%d ms a picture" % budget if budget else "full resolution"
still = "%.0f ms" % cost if cost else "-"
print("%-7s %-18s %9s %12.1f %12.2f %14s" % (shape, label, "%dx%d" % (w, h), fps, least, still))
PY
    done
done
kill $watcher 2>/dev/null
wait $watcher 2>/dev/null || true
# the foam graph's page: a shore made by a pixel node, then foam.frag playing
half=$((size / 2))
cat >"$tmp/shore.wetgraph" <<XML
<wetgraph version="1" size="$half"><node id="s" type="pixel"
  expr="cos(6.283185307179586 * u) + 0.6 * sin(12.566370614359172 * v) &gt; 0.3"/>
  <output name="shore" from="s" format="png"/></wetgraph>
XML
"$build/cli/wetgraph" render "$tmp/shore.wetgraph" -o "$tmp" -q
: >"$tmp/watch.log"
"$build/cli/wetgraph" watch "$root/graphs/foam.wetgraph" -o "$tmp/foam" --size "$half" \
    --input shore="$tmp/shore_shore.png" --serve "$port" >"$tmp/watch.log" 2>&1 &
watcher=$!
until grep -q "watch: waiting" "$tmp/watch.log"; do
    kill -0 $watcher 2>/dev/null || { cat "$tmp/watch.log"; exit 1; }
    sleep 0.2
done
out=$(node "$root/tests/cli/page_driver.js" "http://127.0.0.1:$port/?events=0" \
    "$root/bench/foamview_play.js" "$tmp/profile_foam")
python3 - "$out" "$half" <<'PY'
import json, sys
w, h, n, fps = json.loads(sys.argv[1])
print("foam.frag playing (foam graph at %s²): %dx%d canvas, %.1f pictures a second" % (sys.argv[2], w, h, fps))
PY

