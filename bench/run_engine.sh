#!/bin/sh
# SPDX-License-Identifier: MIT
# The engine benchmark (bench/bench_engine.c): one memcpy of a gray image (into fresh pages and
# into a written buffer) and the per-node time of a chain of 10 point nodes with the buffer
# pool cold, warm and absent, at each SIZE (default 2048 and 4096; one process per size, so the
# first render of each is the process's first), with THREADS workers (default 2), median of
# REPS renders (default 5). Ends with the load average, as timing on a busy machine is noisy.
# Builds the benchmark in BUILD_DIR first (default: build, set up as a release build if
# missing).
# Usage: bench/run_engine.sh [BUILD_DIR] [THREADS] [REPS] [SIZE...]
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
threads=${2:-2}
reps=${3:-5}
[ $# -gt 3 ] && shift 3 || set -- 2048 4096
[ -f "$build/build.ninja" ] || meson setup "$build" "$root" --buildtype=release >/dev/null
ninja -C "$build" bench/bench_engine >/dev/null
for size in "$@"; do
    "$build/bench/bench_engine" --size "$size" --threads "$threads" --reps "$reps"
done
echo "# load average: $(cut -d' ' -f1-3 /proc/loadavg)"
