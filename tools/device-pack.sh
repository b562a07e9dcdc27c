#!/usr/bin/env bash
# Packs this machine's Release build for a run on a lent GPU machine (the
# workplace's `device` tool): the stripped executables, every shared library
# they need beyond glibc/libstdc++ (FFmpeg's tree, pugixml, the Vulkan loader)
# and the Khronos validation layer, as two .tar.xz under .dev/ (git-ignored;
# name `.dev` in the run's `carry`). tools/device-check.sh unpacks and runs them.
# Usage: tools/device-pack.sh [BUILD_DIR]   (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
[[ -x $build/icube-tests ]] || { echo "device-pack: $build/icube-tests missing: build first" >&2; exit 1; }
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/bin" "$stage/lib" .dev
cp "$build"/icube "$build"/icube-tests "$build"/icube-bench* "$stage/bin/"
strip "$stage"/bin/*
for exe in "$stage"/bin/*; do ldd "$exe" | awk '/=>/{print $3}'; done | sort -u |
  grep -v -E '/lib(c|m|pthread|dl|rt|resolv|stdc\+\+|gcc_s)\.so' |
  while read -r lib; do cp -L "$lib" "$stage/lib/"; done
cp -L /usr/lib/x86_64-linux-gnu/libVkLayer_khronos_validation.so "$stage/lib/"
mkdir -p "$stage/layers"
cp /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json "$stage/layers/"
tar -C "$stage" -cJf .dev/bin.tar.xz bin
# The libraries change only with the Debian packages: kept unless REPACK_LIBS=1 (3 min of xz -9e).
if [[ ! -f .dev/lib.tar.xz || -n ${REPACK_LIBS:-} ]]; then
  XZ_OPT=-9e tar -C "$stage" -cJf .dev/lib.tar.xz lib layers
fi
du -ch .dev/*.tar.xz
