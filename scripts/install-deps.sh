#!/usr/bin/env bash
# Installs the dependencies from Debian 12's packages.
#   scripts/install-deps.sh           # everything: build, tests, sanitizers, fuzzers, plots
#   scripts/install-deps.sh program   # only what the cdsm program and the library need
# Idempotent: re-running it only checks that everything is present.
set -euo pipefail

program=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libglfw3-dev libglm-dev
  libegl-dev libgl-dev libgl1-mesa-dri libegl-mesa0
  libimgui-dev libstb-dev libtinygltf-dev nlohmann-json3-dev libcli11-dev
  libopenvdb-dev libnanovdb-dev libboost-iostreams-dev libtbb-dev libblosc-dev
)
tests=(
  clang-14 libclang-rt-14-dev clang-format-14 mesa-utils-bin
  libgtest-dev libgmock-dev libbenchmark-dev
  xvfb xauth python3-matplotlib
)
case ${1:-all} in
  program) packages=("${program[@]}") ;;
  all) packages=("${program[@]}" "${tests[@]}") ;;
  *) echo "usage: $0 [program|all]" >&2; exit 2 ;;
esac

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done

if ((${#missing[@]})); then
  sudo_cmd=()
  [[ $(id -u) -eq 0 ]] || sudo_cmd=(sudo)
  echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}" >&2
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "install-deps: all ${#packages[@]} packages present" >&2
fi
