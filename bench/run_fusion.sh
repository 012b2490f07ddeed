#!/bin/sh
# SPDX-License-Identifier: MIT
# Fused point operations (bench/bench_fusion.c): a gray noise and a chain of 10 point
# operations at each SIZE, fused and unfused, with the default allocator (every render maps its
# images anew) and with a recycling one (image memory warm from the second render on), one
# process per case so each reports its own peak resident memory. Per node: first render, second
# render, best of the rest (REPS renders in all). Builds the benchmark in BUILD_DIR first
# (default: build, set up as a release build if missing). Timing is noisy on a loaded machine.
# Usage: bench/run_fusion.sh [BUILD_DIR] [SIZES] [THREADS] [REPS]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
sizes=${2:-"2048 4096"}
threads=${3:-2}
reps=${4:-10}
[ -f "$build/build.ninja" ] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" bench/bench_fusion >/dev/null
echo "# load average: $(cut -d' ' -f1-3 /proc/loadavg)"
for size in $sizes; do
    for alloc in "" --recycle; do
        for mode in "" --no-fuse; do
            # shellcheck disable=SC2086 # empty options vanish
            "$build/bench/bench_fusion" --size "$size" --threads "$threads" --reps "$reps" $mode $alloc
            echo
        done
    done
done
