#!/usr/bin/env bash
# The main job from a fresh clone: install the Debian packages, build splitray (Release, into
# build/) and render the built-in default scene to splitray.png, printing a summary.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build --target splitray -j "$(nproc)"
build/apps/splitray/splitray render -o splitray.png "$@"
