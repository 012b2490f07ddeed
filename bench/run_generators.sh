#!/usr/bin/env bash
# Generator benchmark: every wetgraph generator at SIZE² next to GEGL's perlin and simplex noise
# at the same size and thread count, in the same run. Prints ms (median of REPS), ms per
# megapixel, and the ratio to GEGL's perlin noise (ours / GEGL: below 1 is faster).
#   bench/run_generators.sh [BUILD_DIR] [SIZE] [THREADS] [REPS]     (defaults: build 2048 2 9)
# Our times are wg_render wall-clock (cache cleared, output allocation included). GEGL's are the
# time its own profiler (GEGL_DEBUG_TIME) gives the noise operation inside the CLI process, so
# process start-up, plug-in loading and writing the file are left out; GEGL_THREADS is set to
# THREADS. GEGL ops: gegl:perlin-noise n=8 (8 octaves, like our fbm8_perlin) and
# gegl:simplex-noise iterations=8, cropped to SIZE². Needs `gegl` (scripts/install-deps.sh
# --bench); without it only our numbers are printed.
set -euo pipefail
build=${1:-build}
size=${2:-2048}
threads=${3:-2}
reps=${4:-9}
src=$(cd "$(dirname "$0")/.." && pwd)
[[ -d "$build" ]] || meson setup "$build" "$src" >/dev/null
ninja -C "$build" bench/bench_generators >/dev/null

ours=$("$build/bench/bench_generators" --size "$size" --threads "$threads" --reps "$reps")

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# gegl_ms OP ARGS...: median over REPS of the op's time (ms) from GEGL_DEBUG_TIME.
gegl_ms() {
    local op=$1
    shift
    local i
    for ((i = 0; i < reps; i++)); do
        GEGL_THREADS=$threads GEGL_DEBUG_TIME=1 gegl -o "$tmp/out.ppm" -- "$op" "$@" \
            gegl:crop width="$size" height="$size" 2>&1 |
            awk -v op="$op" '
                /^Total time:/ { gsub(/s/, "", $3); total = $3 }
                $1 == "process" && !p { p = $2 + 0 }
                $1 == op && !o { o = $2 + 0 }
                END { if (total && p && o) printf "%.2f\n", total * 1000 * p / 100 * o / 100 }'
    done | sort -n | awk '{ v[NR] = $1 } END { if (NR) print v[int((NR + 1) / 2)] }'
}

gp="" gs=""
if command -v gegl >/dev/null 2>&1; then
    # warm the plug-in cache once (the very first start can take seconds)
    gegl -o "$tmp/warm.ppm" -- gegl:perlin-noise gegl:crop width=8 height=8 >/dev/null 2>&1 || true
    gp=$(gegl_ms gegl:perlin-noise n=8)
    gs=$(gegl_ms gegl:simplex-noise iterations=8)
else
    echo "gegl not found: GEGL columns left empty (scripts/install-deps.sh --bench)" >&2
fi

mp=$(awk -v s="$size" 'BEGIN { printf "%.6f", s * s / 1e6 }')
echo "# ${size}x${size}, ${threads} threads, median of ${reps}; ratio = ms / GEGL perlin-noise ms"
printf '%-22s %10s %10s %10s\n' case ms ms/MP ratio
{
    echo "$ours" | grep -v '^#' | awk -F'\t' '{ print $1, $2 }'
    [[ -n "$gp" ]] && echo "gegl:perlin-noise_n8 $gp"
    [[ -n "$gs" ]] && echo "gegl:simplex-noise_i8 $gs"
} | awk -v mp="$mp" -v gp="$gp" '{
        ratio = gp != "" && gp > 0 ? sprintf("%.3f", $2 / gp) : "-"
        printf "%-22s %10.2f %10.2f %10s\n", $1, $2, $2 / mp, ratio
    }'
