#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Renders the pictures of docs/wet.md's "Rain ripples" into docs/img/ (needs a build and
# oiiotool: scripts/install-deps.sh --docs): a contact sheet of the rings on flat water over a
# 1.5-second loop, the Bricks102 wall in the rain at water level 0.75 (the one-surface
# normal and the water layer's normal at one moment, a crop), streaks and beads.
#   scripts/rain_pictures.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
wg=${1:-$root/build}/cli/wetgraph
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# 12 frames of a 1.5-second loop at 8 fps, 256 wide (large drops, steep rings), on a 4x3 grid
"$wg" render "$root/graphs/rain_ripples.wetgraph" --size 256 --set rain=0.6 --set drop_size=24 --set strength=1.5 \
    --set loop_seconds=1.5 --set ripple_seconds=0.75 --output ripplenormal --frames 0:11 \
    --fps 8 -o "$tmp/seq" --contact-sheet "$root/docs/img/rain_sheet.png" -q
sh=$root/../shared/materials/bricks102_stonewall_1k
"$wg" render "$root/graphs/wet_rain.wetgraph" -o "$tmp/wall" -q --time 0.4 \
    --input basecolor=$sh/Bricks102_1K-JPG_Color.jpg \
    --input height=$sh/Bricks102_1K-JPG_Displacement.jpg \
    --input normal=$sh/Bricks102_1K-JPG_NormalGL.jpg \
    --set water_level=0.75 --set rain=0.8 --output normal --output waternormal
oiiotool "$tmp/wall/wet_rain_normal.png" --cut 400x300+300+100 \
    "$tmp/wall/wet_rain_waternormal.png" --cut 400x300+300+100 --mosaic 2x1 \
    -o "$root/docs/img/rain_wall.png"
# streaks on a relief that is steep nearly everywhere (a Perlin height, 96 length units deep)
# at water level 0.3 in rain 0.8: the streaks mask and the base colour, with up the top of the
# image (left pair) and the right of it (up_angle 0, right pair)
cat > "$tmp/relief.wetgraph" <<'XML'
<wetgraph version="1" size="1024x512">
  <node id="n" type="noise" kind="perlin" scale="6" octaves="3" seed="5"/>
  <output name="height" from="n" format="exr32"/>
</wetgraph>
XML
"$wg" render "$tmp/relief.wetgraph" -o "$tmp" -q
for up in 90 0; do
    "$wg" render "$root/graphs/wet_rain.wetgraph" -o "$tmp/streaks$up" -q \
        --input basecolor=$sh/Bricks102_1K-JPG_Color.jpg --input height="$tmp/relief_height.exr" \
        --set height_scale=96 --set water_level=0.3 --set rain=0.8 --set up_angle=$up \
        --output streaks --output basecolor
done
oiiotool "$tmp/streaks90/wet_rain_streaks.png" --ch 0,0,0 --chnames R,G,B --cut 300x300+300+100 \
    "$tmp/streaks90/wet_rain_basecolor.png" --ch R,G,B --cut 300x300+300+100 \
    "$tmp/streaks0/wet_rain_streaks.png" --ch 0,0,0 --chnames R,G,B --cut 300x300+300+100 \
    "$tmp/streaks0/wet_rain_basecolor.png" --ch R,G,B --cut 300x300+300+100 \
    --mosaic 4x1 --resize 75% -o "$root/docs/img/rain_streaks.png"
# beads: the wall made non-porous in rain 0.8, the normal map and the roughness, a crop at 2x
"$wg" render "$root/graphs/wet_rain.wetgraph" -o "$tmp/beads" -q \
    --input basecolor=$sh/Bricks102_1K-JPG_Color.jpg \
    --input height=$sh/Bricks102_1K-JPG_Displacement.jpg \
    --input normal=$sh/Bricks102_1K-JPG_NormalGL.jpg \
    --set water_level=0.3 --set rain=0.8 --set porosity=0 --output normal --output roughness
oiiotool "$tmp/beads/wet_rain_normal.png" --ch R,G,B --cut 200x150+350+150 --resize 200% \
    "$tmp/beads/wet_rain_roughness.png" --ch 0,0,0 --chnames R,G,B --cut 200x150+350+150 \
    --resize 200% --mosaic 2x1 -o "$root/docs/img/rain_beads.png"
echo "wrote docs/img/rain_sheet.png docs/img/rain_wall.png docs/img/rain_streaks.png docs/img/rain_beads.png"
