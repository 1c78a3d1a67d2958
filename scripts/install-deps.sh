#!/usr/bin/env bash
# Installs every Debian 12 package that splitray's build, tests and main job need.
# Idempotent: when all of them are installed already it only checks and returns (no apt).
# Runs apt-get as root, or through sudo when not root. `--checks` adds what the fuzzing and
# sanitizer step (.ci/checks) needs: clang with libFuzzer and its sanitizer runtimes.
set -euo pipefail

packages=(
  # build
  cmake g++ make pkg-config
  # libraries
  libembree-dev libtbb-dev libassimp-dev zlib1g-dev nlohmann-json3-dev libcli11-dev libfmt-dev
  libstb-dev libnanoflann-dev libflann-dev liblz4-dev
  # HDR image output (OpenEXR), NumPy-format tests, the man page, bash completion
  libopenexr-dev python3-numpy help2man bash-completion
  # OpenGL (hybrid renderer: EGL headless on Mesa llvmpipe, GLFW windows under Xvfb), plots
  libglm-dev libegl-dev libgl-dev libopengl-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev xvfb xauth
  python3-matplotlib
  # neural builder training (train/, paper 003): only splitray-train links it
  libtorch-dev
  # distributed render and animate under mpirun (optional at build time)
  libopenmpi-dev openmpi-bin
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # the Python module (pybind11 for Debian's python3) and its tests; the Python benchmark's
  # peers (scipy's cKDTree, Open3D's RaycastingScene)
  python3-dev pybind11-dev python3-pybind11 python3-pytest python3-scipy python3-open3d
)
case "${1:-}" in
  "") ;;
  --checks) packages+=(clang libclang-rt-14-dev) ;;
  *) echo "usage: scripts/install-deps.sh [--checks]" >&2; exit 2 ;;
esac

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$package")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages are installed"
  exit 0
fi

if [[ $(id -u) -eq 0 ]]; then
  as_root=()
elif command -v sudo > /dev/null; then
  as_root=(sudo)
else
  echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2
  exit 1
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt_install() {
  "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive \
    apt-get install -y --no-install-recommends "${missing[@]}"
}
# Update the package lists only when they are missing (fresh images) or the install fails
# on stale ones.
if ! compgen -G "/var/lib/apt/lists/*_Packages*" > /dev/null; then
  "${as_root[@]}" apt-get update
  apt_install
elif ! apt_install; then
  "${as_root[@]}" apt-get update
  apt_install
fi
echo "install-deps: done"
