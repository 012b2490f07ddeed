#!/bin/sh
# SPDX-License-Identifier: MIT
# The pixel-node benchmark (bench/bench_pixel.c): the `pixel` node against the same maths
# written in C, 2048x2048 by default, best of RUNS runs. Builds the benchmark in BUILD_DIR
# first (default: build, set up as a release build if missing). Timing is noisy on a loaded
# machine: run it on an idle one.
# Usage: bench/run_pixel.sh [BUILD_DIR] [SIZE] [RUNS]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
[ -f "$build/build.ninja" ] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" bench/bench_pixel >/dev/null
exec "$build/bench/bench_pixel" "${2:-2048}" "${3:-7}"
