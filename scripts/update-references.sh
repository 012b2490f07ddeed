#!/usr/bin/env bash
# Re-render the reference images of tests/graphs/ (the only way they change). Review the diff
# of the pictures before committing them.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh
WETGRAPH_UPDATE_REFERENCES=1 meson test -C build --suite graphs --verbose | grep updated || true
