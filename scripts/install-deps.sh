#!/usr/bin/env bash
# Installs every dependency of papertear from Debian 12 packages. Idempotent: when every package is
# already installed it does not touch apt at all.
set -euo pipefail
PKGS=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libtbb-dev libembree-dev libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  nlohmann-json3-dev libcli11-dev libstb-dev libpng-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  libglfw3-dev libgl-dev libimgui-dev xvfb xauth
  pybind11-dev python3-dev python3-numpy python3-jsonschema
  clang libclang-rt-14-dev
  libopenmpi-dev openmpi-bin
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
