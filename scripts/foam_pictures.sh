#!/usr/bin/env bash
# Renders the pictures of docs/foam.md into docs/img/ (needs a build: bash scripts/test.sh or
# meson setup build && ninja -C build): the example shore, one foam frame with its preview, and
# a contact sheet of a looping second of animation.
#   scripts/foam_pictures.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
wg=${1:-$root/build}/cli/wetgraph
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$wg" render "$root/graphs/examples/shore.wetgraph" -o "$tmp" -q
"$wg" render "$root/graphs/foam.wetgraph" --input shore="$tmp/shore_land.png" --size 512 \
    --output preview --output foam --time 0 -o "$tmp" -q
cp "$tmp/foam_preview.png" "$root/docs/img/foam_preview.png"
cp "$tmp/foam_foam.png" "$root/docs/img/foam_foam.png"
# 12 frames of a 2-second loop at 6 fps, shrunk to 256 wide on a 4x3 grid
"$wg" render "$root/graphs/foam.wetgraph" --input shore="$tmp/shore_land.png" --size 256 \
    --set loop_seconds=2 --output preview --frames 0:11 --fps 6 -o "$tmp/seq" \
    --contact-sheet "$root/docs/img/foam_sheet.png" -q
echo "wrote docs/img/foam_preview.png docs/img/foam_foam.png docs/img/foam_sheet.png"
