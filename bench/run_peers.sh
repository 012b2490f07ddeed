#!/usr/bin/env bash
# Blur and distance against their peers, OpenCV (bench/peer_opencv, same process and data as
# wetgraph) and scipy.ndimage (bench/peer_scipy.py, on the inputs and float64 references
# peer_opencv writes), on the same machine in one run. The raw results replace this host's
# earlier ones in bench/peers/<host>.tsv (the host named by its CPU model and core count; other
# hosts' runs are kept as they are); then bench/report.md and its report-<host>.svg pictures are
# regenerated from all of them, a row per host. Installs the peers first
# (scripts/install-deps.sh --bench) and builds. Results vary with machine load.
#   bench/run_peers.sh [BUILD_DIR] [SIZES (default "1024 2048 4096")] [THREADS] [REPS]
#   bench/run_peers.sh --report-only     (regenerate the report from bench/peers/)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
py=/usr/bin/python3  # Debian's, which has python3-numpy and python3-scipy
if [[ "${1:-}" != "--report-only" ]]; then
    build=${1:-$root/build}
    sizes=${2:-1024 2048 4096}
    threads=${3:-2}
    reps=${4:-5}
    "$root/scripts/install-deps.sh" --bench
    [[ -f "$build/build.ninja" ]] || meson setup "$build" "$root" --buildtype=release >/dev/null
    meson configure "$build" >/dev/null  # picks up OpenCV if it was just installed
    ninja -C "$build" >/dev/null
    [[ -x "$build/bench/peer_opencv" ]] || { echo "run_peers.sh: $build/bench/peer_opencv was not built (OpenCV not found)" >&2; exit 1; }
    "$build/bench/peer_opencv" --check
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
    out="$tmp/peers.tsv"
    {
        echo "# date: $(date -u '+%Y-%m-%d %H:%M UTC')"
        echo "# cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(nproc) cores"
        echo "# load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
    } >"$out"
    for n in $sizes; do
        echo "== $n²" >&2
        "$build/bench/peer_opencv" --size "$n" --threads "$threads" --reps "$reps" --dir "$tmp" | tee -a "$out" >&2
        "$py" "$root/bench/peer_scipy.py" "$tmp" "$n" "$reps" | tee -a "$out" >&2
        rm -f "$tmp"/*.f32 "$tmp"/*.f64 "$tmp"/*.u8
    done
    echo "# load average at end: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$out"
    host=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 |
        sed 's/([RrTtMm]*)//g; s/ CPU / /; s/@.*//' | tr 'A-Z' 'a-z' |
        sed 's/[^a-z0-9]\{1,\}/-/g; s/^-//; s/-$//')-$(nproc)c
    mkdir -p "$root/bench/peers"
    cp "$out" "$root/bench/peers/$host.tsv"
    echo "results: bench/peers/$host.tsv" >&2
fi
"$py" "$root/bench/peer_report.py" "$root/bench/peers" "$root/bench/report.md"
