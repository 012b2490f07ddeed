# The material the wet benchmarks render (Bricks102, 1K, from ../shared), as the
# five --input arguments of wet_material and the graphs built on it.
# Sourced by the run_*.sh scripts once they have set $root.
bricks=$root/../shared/materials/bricks102_stonewall_1k
bricks_inputs=(
    --input basecolor="$bricks/Bricks102_1K-JPG_Color.jpg"
    --input height="$bricks/Bricks102_1K-JPG_Displacement.jpg"
    --input normal="$bricks/Bricks102_1K-JPG_NormalGL.jpg"
    --input roughness="$bricks/Bricks102_1K-JPG_Roughness.jpg"
    --input ao="$bricks/Bricks102_1K-JPG_AmbientOcclusion.jpg"
)
