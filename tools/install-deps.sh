#!/usr/bin/env bash
# Installs InfiniCube-VK's build and run-time dependencies from Debian 12 packages.
# Idempotent and quiet: does nothing when everything is already installed.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools glslang-tools
  libglfw3-dev libglm-dev libimgui-dev libtinygltf-dev libstb-dev
  doctest-dev nlohmann-json3-dev libcli11-dev libpugixml-dev
  libavcodec-dev libavformat-dev libavutil-dev libswscale-dev zlib1g-dev libssl-dev librandom123-dev libspng-dev
  python3-numpy
  xvfb xauth
)

# Test-only: PyTorch for the checkpoint converter's test and the benchmarks against
# PyTorch (never the icube runtime; ~120 MB download).
test_packages=(python3-torch python3-omegaconf)

case "${1:-}" in
  -h|--help)
    echo "usage: tools/install-deps.sh [--test]   install the Debian 12 packages InfiniCube-VK needs (as root);"
    echo "       --test adds what the test suite and benchmarks use besides (python3-torch, python3-omegaconf)"
    exit 0 ;;
  --test) packages+=("${test_packages[@]}") ;;
  "") ;;
  *) echo "install-deps: unknown argument '$1' (see --help)" >&2; exit 2 ;;
esac

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
