#!/usr/bin/env bash
# The main job from a fresh clone: install the Debian packages, build splitray (Release, into
# build/) and render the built-in default scene to splitray.png, printing a summary.
# Arguments go to `splitray render` (e.g. -o FILE.exr -W 1920 -H 1080; -o replaces the default
# splitray.png); relative paths are taken from the folder the script is run from.
# SPLITRAY_NO_SETUP=1 skips the install and build steps (an existing build is used);
# SPLITRAY_BUILD_DIR names the build folder (default: build/ of the clone).
set -euo pipefail
caller=$PWD
cd "$(dirname "${BASH_SOURCE[0]}")/.."
root=$PWD
build=${SPLITRAY_BUILD_DIR:-$root/build}

if [[ ${SPLITRAY_NO_SETUP:-0} != 1 ]]; then
  bash scripts/install-deps.sh
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release
  cmake --build "$build" --target splitray -j "$(nproc)"
fi

output_given=false
for arg in "$@"; do
  case "$arg" in -o | -o?* | --output | --output=*) output_given=true ;; esac
done
args=("$@")
$output_given || args=(-o splitray.png "$@")
cd "$caller"
"$build/apps/splitray/splitray" render "${args[@]}"
