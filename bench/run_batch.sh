#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# One process against many: graphs/wet_material.wetgraph over 20 materials, the three shared
# materials under ../shared/materials each at several water levels (rows grouped by material),
# rendered (1) by one `wetgraph render --batch LIST` and (2) by 20 `wetgraph render` processes
# one after the other, each with the same inputs and values as its row. Prints both wall times
# and the saving, and checks that both wrote the same files byte for byte. The batch saves the
# process start, the reading and preparing of each material's maps (once per material instead
# of once per row) and every node that does not depend on the water level.
# Usage: bench/run_batch.sh [BUILD_DIR] [THREADS] [SIZE]   (SIZE: default the materials' own)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
threads=${2:-2}
size=${3:-}
[[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph >/dev/null
wg=$build/cli/wetgraph
m=$root/../shared/materials
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
materials=(
    "$m/bricks102_stonewall_1k/Bricks102_1K-JPG_Color.jpg,$m/bricks102_stonewall_1k/Bricks102_1K-JPG_Displacement.jpg,$m/bricks102_stonewall_1k/Bricks102_1K-JPG_NormalGL.jpg,$m/bricks102_stonewall_1k/Bricks102_1K-JPG_Roughness.jpg"
    "$m/pavingstones130_1k/PavingStones130_1K_Color.jpg,$m/pavingstones130_1k/PavingStones130_1K_Displacement.jpg,$m/pavingstones130_1k/PavingStones130_1K_NormalGL.jpg,$m/pavingstones130_1k/PavingStones130_1K_Roughness.jpg"
    "$m/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_diff_1k.jpg,$m/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_disp_1k.png,$m/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_nor_gl_1k.png,$m/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_rough_1k.png"
)
list=$tmp/materials.csv
echo "input:basecolor,input:height,input:normal,input:roughness,set:water_level,out" > "$list"
rows=20
for ((i = 0; i < rows; i++)); do
    k=$((i * 3 / rows))
    printf '%s,0.%02d,out/row%02d\n' "${materials[$k]}" $((35 + 3 * i)) "$i" >> "$list"
done
opts=(--threads "$threads" -q)
[[ -n "$size" ]] && opts+=(--size "$size")
echo "wet_material, $rows materials (3 material sets x water levels), $threads threads${size:+, ${size}x$size};" \
     "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
t0=$(date +%s.%N)
"$wg" render "$root/graphs/wet_material.wetgraph" --batch "$list" "${opts[@]}"
t1=$(date +%s.%N)
tail -n +2 "$list" | while IFS=, read -r color height normal rough level out; do
    "$wg" render "$root/graphs/wet_material.wetgraph" -o "$tmp/single/$out" "${opts[@]}" \
        --input basecolor="$color" --input height="$height" --input normal="$normal" \
        --input roughness="$rough" --set water_level="$level"
done
t2=$(date +%s.%N)
diff -r "$tmp/out" "$tmp/single/out" >/dev/null || { echo "the batch and the single renders differ" >&2; exit 1; }
python3 - "$t0" "$t1" "$t2" "$rows" <<'PY'
import sys
t0, t1, t2, rows = float(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
batch, single = t1 - t0, t2 - t1
print("one process (--batch): %.1f s (%.2f s a material)" % (batch, batch / rows))
print("%d processes:          %.1f s (%.2f s a material)" % (rows, single, single / rows))
print("saving: %.1f s, %.0f %% (%.2fx faster); outputs identical" % (single - batch, 100 * (single - batch) / single, single / batch))
PY
