#!/usr/bin/env bash
# Install the dependencies, build, install wetgraph (meson's prefix, /usr/local: the program on
# the PATH, its graphs found by name, its manual page and bash completion) and render the demo
# into out/: the Bricks102 stone wall from ../shared wet up to three water levels with the
# built-in wet_material graph (zone masks, wet maps, water layer maps), one folder per level:
# out/water_0.5/wet_material_basecolor.png, ... Extra arguments are passed to every render
# (e.g. --set liquid=tea).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
sudo=
[[ $(id -u) == 0 ]] || sudo=sudo
$sudo meson install -C build --quiet --no-rebuild
$sudo ldconfig
command -v wetgraph >/dev/null || export PATH=/usr/local/bin:$PATH
mat=../shared/materials/bricks102_stonewall_1k
for level in 0.5 0.6 0.7; do
    wetgraph render wet_material -o out/water_$level \
        --input basecolor=$mat/Bricks102_1K-JPG_Color.jpg \
        --input height=$mat/Bricks102_1K-JPG_Displacement.jpg \
        --input normal=$mat/Bricks102_1K-JPG_NormalGL.jpg \
        --input roughness=$mat/Bricks102_1K-JPG_Roughness.jpg \
        --input ao=$mat/Bricks102_1K-JPG_AmbientOcclusion.jpg \
        --set water_level=$level "$@"
done
