#!/usr/bin/env bash
# Run every benchmark against its peers in one go (timings are measured and reported, never
# asserted by the tests). Installs the peers first (scripts/install-deps.sh --bench) and builds.
# Results vary with machine load: run on an idle machine. bench/README.md records a run.
#   bench/run.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
"$root/scripts/install-deps.sh" --bench
[[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" >/dev/null
echo "== generators vs GEGL (2048², 2 threads)"
"$root/bench/run_generators.sh" "$build" 2048 2 9
echo
echo "== pixel node vs the same maths in C (2048²)"
"$root/bench/run_pixel.sh" "$build" 2048 7
echo
echo "== graph size: 1k, 10k, 100k nodes (whole process; peer: xmllint parsing the same file)"
"$root/bench/run_scaling.sh" "$build" 3
echo
echo "== distance, dilate, erode (2048², 2 threads; node time only)"
"$build/bench/bench_distance" --size 2048 --threads 2 --reps 9
echo
echo "== normal, slope vs a memcpy (2048², 2 threads)"
"$build/bench/bench_normal" --size 2048 --threads 2 --reps 9
echo
echo "== warp, directional_warp, transform (2048², 2 threads)"
"$build/bench/bench_warp" --size 2048 --threads 2 --reps 9
echo
echo "== sharpen, emboss, edge_detect, directional_blur, normal_blend, normal_normalize (2048², 2 threads)"
"$build/bench/bench_filters" --size 2048 --threads 2 --reps 9
echo
echo "== blur fast vs exact (2048² gray, 2 threads; exact takes tens of seconds)"
"$build/bench/bench_blur" --size 2048 --threads 2 --reps 15
echo
echo "== start-up and image reading (whole process; image node vs OpenImageIO)"
"$root/bench/run_io.sh" "$build" 11
