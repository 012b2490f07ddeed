#!/usr/bin/env bash
# Renders the pictures of docs/foam.md into docs/img/ (needs a build: bash scripts/test.sh or
# meson setup build && ninja -C build): the example shore, one foam frame with its preview, a
# contact sheet of a looping second of animation, and foam following a painted profile.
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
# a painted distance texture used as it is (pattern_mode profile): a profile with soft and hard
# fall-offs (tileable cell blobs, eased differently left and right), and the foam at two
# thresholds following it (the texture term alone: no sine, warp, second layer or thinning)
cat > "$tmp/profile.wetgraph" <<'XML'
<wetgraph version="1" size="512">
  <node id="c" type="cells" scale="6" seed="3"/>
  <node id="p" type="pixel" expr="d = clamp(1 - 2.2 * f, 0, 1); u &lt; 0.5 ? d * d : sqrt(d)">
    <in name="f" from="c.f1"/>
  </node>
  <output name="pattern" from="p" format="png16"/>
</wetgraph>
XML
"$wg" render "$tmp/profile.wetgraph" -o "$tmp" -q
for th in 0.3 0.6; do
    "$wg" render "$root/graphs/foam.wetgraph" --input shore="$tmp/shore_land.png" --size 512 \
        --input pattern="$tmp/profile_pattern.png" --set pattern_mode=profile --set ratio_sine=0 \
        --set ratio_tex=1 --set warp_amp=0 --set layer2=0 --set a=0 --set b=0 \
        --set reach_noise=0 --set threshold_noise=0 --set band_width=256 --set inland_reach=1 \
        --set threshold=$th --output foam --time 0 -o "$tmp/prof$th" -q
done
oiiotool "$tmp/profile_pattern.png" --ch 0,0,0 --chnames R,G,B \
    "$tmp/prof0.3/foam_foam.png" --ch 0,0,0 --chnames R,G,B \
    "$tmp/prof0.6/foam_foam.png" --ch 0,0,0 --chnames R,G,B \
    --mosaic 3x1 --resize 50% -o "$root/docs/img/foam_profile.png"
echo "wrote docs/img/foam_preview.png docs/img/foam_foam.png docs/img/foam_sheet.png docs/img/foam_profile.png"
