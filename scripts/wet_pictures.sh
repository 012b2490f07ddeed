#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Render the pictures of docs/wet.md into docs/img/ from the shared materials (../shared):
# the Bricks102 wall wet at several water levels (base colour and zone views), the dry and wet
# roughness and normal maps, the six liquid presets, wood and paving, and the same crop
# rendered at 1K and 2K (resolution independence). Crops and tiles with oiiotool
# (openimageio-tools, installed by scripts/install-deps.sh --docs); small 8-bit PNGs.
# Usage: scripts/wet_pictures.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
build=${1:-build}
scripts/install-deps.sh --docs
[[ -f "$build/build.ninja" ]] || meson setup "$build" --buildtype=release >/dev/null
ninja -C "$build" cli/wetgraph >/dev/null
wg="$root/$build/cli/wetgraph"
[[ -x "$wg" ]] || wg="$build/cli/wetgraph"
img=docs/img
mkdir -p "$img"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
sh=../shared/materials
bricks=(--input basecolor=$sh/bricks102_stonewall_1k/Bricks102_1K-JPG_Color.jpg
        --input height=$sh/bricks102_stonewall_1k/Bricks102_1K-JPG_Displacement.jpg
        --input normal=$sh/bricks102_stonewall_1k/Bricks102_1K-JPG_NormalGL.jpg
        --input roughness=$sh/bricks102_stonewall_1k/Bricks102_1K-JPG_Roughness.jpg
        --input ao=$sh/bricks102_stonewall_1k/Bricks102_1K-JPG_AmbientOcclusion.jpg)
paving=(--input basecolor=$sh/pavingstones130_1k/PavingStones130_1K_Color.jpg
        --input height=$sh/pavingstones130_1k/PavingStones130_1K_Displacement.jpg
        --input normal=$sh/pavingstones130_1k/PavingStones130_1K_NormalGL.jpg
        --input roughness=$sh/pavingstones130_1k/PavingStones130_1K_Roughness.jpg
        --input ao=$sh/pavingstones130_1k/PavingStones130_1K_AmbientOcclusion.jpg)
wood=(--input basecolor=$sh/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_diff_1k.jpg
      --input height=$sh/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_disp_1k.png
      --input normal=$sh/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_nor_gl_1k.png
      --input roughness=$sh/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_rough_1k.png)
render() { # out_dir args...
    local out=$1
    shift
    "$wg" render graphs/wet_material.wetgraph -o "$tmp/$out" -q "$@"
}
# one panel: a crop of a rendered map, halved (crop WxH+X+Y of the 1K image)
panel() { # file crop out
    oiiotool "$1" --ch R,G,B --cut "$2" --resize 40% -o "$3"
}
gpanel() { # gray file crop out
    oiiotool "$1" --ch 0,0,0 --chnames R,G,B --cut "$2" --resize 40% -o "$3"
}
crop=400x300+300+100

# water levels: base colour (dry first) and zones, at full size: 512 x 384 of the 1K maps each
render dry "${bricks[@]}" --set water_level=0 --output basecolor --output zones
levels=(0.5 0.6 0.7)
for l in "${levels[@]}"; do render "l$l" "${bricks[@]}" --set water_level=$l; done
big=512x384+250+80
oiiotool "$tmp/dry/wet_material_basecolor.png" --ch R,G,B --cut $big -o "$tmp/b0.png"
oiiotool "$tmp/dry/wet_material_zones.png" --ch R,G,B --cut $big -o "$tmp/z0.png"
for l in "${levels[@]}"; do
    oiiotool "$tmp/l$l/wet_material_basecolor.png" --ch R,G,B --cut $big -o "$tmp/b$l.png"
    oiiotool "$tmp/l$l/wet_material_zones.png" --ch R,G,B --cut $big -o "$tmp/z$l.png"
done
oiiotool "$tmp/b0.png" "$tmp/b0.5.png" --mosaic 2x1 -o $img/wet_levels.png
oiiotool "$tmp/b0.6.png" "$tmp/b0.7.png" --mosaic 2x1 -o $img/wet_levels_high.png
oiiotool "$tmp/z0.png" "$tmp/z0.5.png" "$tmp/z0.6.png" "$tmp/z0.7.png" --mosaic 4x1 --resize 50% \
    -o $img/wet_zones.png

# dry and wet roughness and normal at level 0.6
render drymaps "${bricks[@]}" --set water_level=0 --output roughness --output normal
gpanel "$tmp/drymaps/wet_material_roughness.png" $crop "$tmp/r0.png"
gpanel "$tmp/l0.6/wet_material_roughness.png" $crop "$tmp/r1.png"
panel "$tmp/drymaps/wet_material_normal.png" $crop "$tmp/n0.png"
panel "$tmp/l0.6/wet_material_normal.png" $crop "$tmp/n1.png"
oiiotool "$tmp/r0.png" "$tmp/r1.png" "$tmp/n0.png" "$tmp/n1.png" --mosaic 4x1 -o $img/wet_maps.png

# the liquid presets at level 0.7
for q in water muddy_water tea milk blood oil; do
    render "q$q" "${bricks[@]}" --set water_level=0.7 --set liquid=$q --output basecolor
    oiiotool "$tmp/q$q/wet_material_basecolor.png" --ch R,G,B --cut 300x250+400+100 --resize 40% \
        -o "$tmp/q$q.png"
done
oiiotool "$tmp"/qwater.png "$tmp"/qmuddy_water.png "$tmp"/qtea.png "$tmp"/qmilk.png \
    "$tmp"/qblood.png "$tmp"/qoil.png --mosaic 6x1 -o $img/wet_liquids.png

# paving stones and wood: dry and wet
render pdry "${paving[@]}" --set water_level=0 --output basecolor
render pwet "${paving[@]}" --set water_level=0.75 --output basecolor --output zones
render wdry "${wood[@]}" --set water_level=0 --output basecolor
render wwet "${wood[@]}" --set water_level=0.7 --output basecolor --output zones
for f in pdry pwet wdry wwet; do panel "$tmp/$f/wet_material_basecolor.png" 400x300+200+200 "$tmp/$f.png"; done
panel "$tmp/pwet/wet_material_zones.png" 400x300+200+200 "$tmp/pz.png"
panel "$tmp/wwet/wet_material_zones.png" 400x300+200+200 "$tmp/wz.png"
oiiotool "$tmp/pdry.png" "$tmp/pwet.png" "$tmp/pz.png" "$tmp/wdry.png" "$tmp/wwet.png" "$tmp/wz.png" \
    --mosaic 6x1 --resize 75% -o $img/wet_materials.png

# 1K and 2K: the same area, the 2K render halved
render k1 "${bricks[@]}" --set water_level=0.6 --output basecolor
render k2 "${bricks[@]}" --size 2048x1024 --set water_level=0.6 --output basecolor
oiiotool "$tmp/k1/wet_material_basecolor.png" --ch R,G,B --cut 150x150+350+150 -o "$tmp/k1.png"
oiiotool "$tmp/k2/wet_material_basecolor.png" --ch R,G,B --cut 300x300+700+300 --resize 150x150 \
    -o "$tmp/k2.png"
oiiotool "$tmp/k1.png" "$tmp/k2.png" --mosaic 2x1 -o $img/wet_1k_2k.png
# a painted level: a water plane tilted from 0.35 (left) to 0.75 (right) of the height range
oiiotool --pattern fill:left=0.35:right=0.75 1024x512 1 -d float -o "$tmp/tilt.exr"
render tilt "${bricks[@]}" --input level="$tmp/tilt.exr" --output basecolor --output zones
oiiotool "$tmp/tilt/wet_material_basecolor.png" --ch R,G,B --resize 50% -o "$tmp/tb.png"
oiiotool "$tmp/tilt/wet_material_zones.png" --ch R,G,B --resize 50% -o "$tmp/tz.png"
oiiotool "$tmp/tb.png" "$tmp/tz.png" --mosaic 2x1 -o $img/wet_level.png

# drying: the water dropped from 0.75 to 0.45 of the height range; zones (top) and base colour
# (bottom) at drying 0, 0.25, 0.5 and 0.8
drying=(0 0.25 0.5 0.8)
for d in "${drying[@]}"; do
    render "d$d" "${bricks[@]}" --set water_level=0.45 --set high_water=0.75 --set drying=$d \
        --output basecolor --output zones
    panel "$tmp/d$d/wet_material_zones.png" $crop "$tmp/dz$d.png"
    panel "$tmp/d$d/wet_material_basecolor.png" $crop "$tmp/db$d.png"
done
oiiotool "$tmp"/dz{0,0.25,0.5,0.8}.png "$tmp"/db{0,0.25,0.5,0.8}.png --mosaic 4x2 -o $img/wet_drying.png
# rain on the exposed wall (water level 0.45): zones (top) and base colour (bottom) at rain 0,
# 0.25, 0.5 and 1
rains=(0 0.25 0.5 1)
for r in "${rains[@]}"; do
    render "r$r" "${bricks[@]}" --set water_level=0.45 --set rain=$r --output basecolor --output zones
    panel "$tmp/r$r/wet_material_zones.png" $crop "$tmp/rz$r.png"
    panel "$tmp/r$r/wet_material_basecolor.png" $crop "$tmp/rb$r.png"
done
oiiotool "$tmp"/rz{0,0.25,0.5,1}.png "$tmp"/rb{0,0.25,0.5,1}.png --mosaic 4x2 -o $img/wet_rain.png
ls -l $img/wet_*.png
