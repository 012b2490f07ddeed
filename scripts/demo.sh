#!/usr/bin/env bash
# Install, build and render the demo into out/: a wet-look preview of the PavingStones130
# material from ../shared (darker, glossier where the height map is low).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
mat=../shared/materials/pavingstones130_1k
./build/cli/wetgraph render graphs/demo.wetgraph -o out \
    --input basecolor=$mat/PavingStones130_1K_Color.jpg \
    --input height=$mat/PavingStones130_1K_Displacement.jpg \
    --input roughness=$mat/PavingStones130_1K_Roughness.jpg \
    --set water_level=0.72 "$@"
