#!/usr/bin/env bash
# Configure (once) and build an optimised wetgraph in build/.
set -euo pipefail
cd "$(dirname "$0")/.."
[[ -f build/build.ninja ]] || meson setup build --buildtype=release >/dev/null
ninja -C build >/dev/null
