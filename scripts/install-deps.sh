#!/usr/bin/env bash
# Install the Debian packages wetgraph needs: only those missing, quietly, idempotently.
#   scripts/install-deps.sh          build and test dependencies
#   scripts/install-deps.sh --bench  also the peers the benchmarks compare against
#   scripts/install-deps.sh --docs   also oiiotool (scripts/wet_pictures.sh crops and tiles)
set -euo pipefail
pkgs=(meson ninja-build pkg-config gcc g++ libxml2-dev libopenimageio-dev libopenexr-dev
      libxxhash-dev zlib1g-dev libcmocka-dev libfftw3-dev
      libdeflate-dev  # the PNG writer's deflate (io/png_write.c)
      libjson-c-dev  # the JSON of glTF assets (io/gltf.c)
      libjpeg62-turbo-dev  # JPEG pixels decoded with libjpeg-turbo (io/jpeg_read.c)
      libmicrohttpd-dev  # `wetgraph watch --serve` (optional: built without it when missing)
      chromium  # the headless-browser test of the --serve page (tests/cli/test_serve_page.c)
      glslang-tools  # the tests validate the GLSL shaders in docs/shaders
      # ... and execute them headless (tests/graphs/test_glsl.c): EGL and desktop GL headers,
      # Mesa's EGL and its software rasteriser llvmpipe
      libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri
      help2man  # the manual page, from `wetgraph --help-all`
      bash-completion  # where the bash completion is installed, and bash's completion itself
      clang libclang-rt-14-dev  # the libFuzzer targets (scripts/fuzz.sh): clang and its runtime
      # the Python module (python/) for Debian's python3, and its pytest suite, which reads the
      # command line's files with OpenImageIO's binding
      python3-dev python3-numpy python3-pytest python3-openimageio
      # the Blender add-on's headless test (python/tests/test_blender.py): Debian's Blender
      # runs on the same python3; about 190 MB with its data, in the range of chromium above
      blender)
if [[ "${1:-}" == "--bench" ]]; then
    pkgs+=(gegl libxml2-utils  # peers of the benchmarks
           libopencv-dev python3-scipy  # blur and distance peers (bench/run_peers.sh)
           openimageio-tools  # oiiotool, the image-reading peer (bench/run_io.sh)
           python3-opencv)  # cv2.imwrite, the PNG-writing peer (bench/run_write.sh)
    # Blender (Cycles, the path tracer the preview is held against in bench/run_cycles.sh) is
    # in the list above: the add-on's test needs it too
fi
if [[ "${1:-}" == "--docs" ]]; then
    pkgs+=(openimageio-tools)
fi
# Khronos glTF-Validator checks the exported assets (tools/gltf-validator, from npm): node and
# npm from Debian unless the machine has them already (some install nodejs with its own npm)
command -v node >/dev/null || pkgs+=(nodejs)
command -v npm >/dev/null || pkgs+=(npm)
missing=()
for p in "${pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
validator() { # the validator's npm package, at the version its lock file names
    local dir
    dir="$(dirname "$0")/../tools/gltf-validator"
    [[ -f "$dir/node_modules/gltf-validator/package.json" ]] ||
        (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
}
if [[ ${#missing[@]} -eq 0 ]]; then
    validator
    exit 0
fi
sudo=""
[[ "$(id -u)" -ne 0 ]] && sudo="sudo"
echo "wetgraph: installing ${missing[*]}" >&2
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
validator
