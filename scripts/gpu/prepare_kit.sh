#!/usr/bin/env bash
# Prepares the folder a GPU machine takes along (docs/gpu.md): the Debian 12
# packages the GPU build needs that such a machine lacks (it has CMake, ninja,
# g++ and nvcc, no network and no -dev packages), fetched here with
# `apt-get download` into build-kit/debs/ (build*/ is ignored by git). On the
# GPU machine scripts/gpu/run_kit.sh unpacks them with `dpkg -x` into
# build-kit/prefix/, never into /. The .deb files stay compressed: the whole
# folder must stay under the device tool's 64 MiB (checked at the end).
#
# Usage: bash scripts/gpu/prepare_kit.sh        (root or sudo; needs Debian's package lists)
set -euo pipefail
cd "$(dirname "$0")/../.."
kit=build-kit
mkdir -p "$kit/debs"

# What the `gpu` preset needs (CDSM_VDB=OFF, CDSM_EDITOR=OFF):
packages=(
  # threads
  libtbb-dev libtbb12 libtbbmalloc2 libtbbbind-2-5 libhwloc15
  # tests
  libgtest-dev libgmock-dev googletest
  # scenes, images, glTF, NanoVDB (header-only, used by the kernels)
  nlohmann-json3-dev libstb-dev libstb0 libtinygltf-dev libtinygltf2d libnanovdb-dev
  # OpenGL + EGL through libglvnd (headers, loader libraries; the vendor library is the GPU driver's)
  libegl-dev libgl-dev libglx-dev libopengl-dev libglvnd-dev libegl1 libgl1 libglx0 libopengl0 libglvnd0
  # pkg-config (CMake's pkg_check_modules for stb)
  pkgconf pkgconf-bin libpkgconf3
)

if ! apt-get download --print-uris libtbb-dev >/dev/null 2>&1; then apt-get update -qq; fi
(cd "$kit/debs" && apt-get download -q "${packages[@]}")

# The pieces a run needs besides the packages, so the kit describes itself.
printf '%s\n' "${packages[@]}" >"$kit/packages.txt"
rm -rf "$kit/prefix"  # unpacked on the GPU machine only

bytes=$(du -sb "$kit" | cut -f1)
echo "build-kit: $(ls "$kit/debs" | wc -l) packages, $((bytes / 1024)) KiB"
if ((bytes > 48 * 1024 * 1024)); then
  echo "build-kit is over 48 MiB: the working tree and the kit must travel in 64 MiB together" >&2
  exit 1
fi
