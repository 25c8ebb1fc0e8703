#!/usr/bin/env bash
# Configures and builds the project into build/ (Release).
# Usage: scripts/build.sh [--cuda guard|auto|on|off] [--target T]... [extra cmake args...]
#   --cuda guard (default): the CUDA backend is compiled whenever nvcc is
#                 found, GPU or not (the test command's compile guard).
#                 Without an NVIDIA driver only PTX is generated (90-virtual:
#                 the CUDA and C++ front ends check every kernel; ptxas,
#                 four fifths of the kernels' compile time, is skipped, since
#                 nothing could run its code here).
#   --cuda auto:  compiled only where it can run: nvcc found and an NVIDIA
#                 driver loaded (/proc/driver/nvidia/version, or libcuda.so.1
#                 known to the loader); $CDSM_CUDA=1 / 0 forces it on / off.
#                 Prints what it decided and why.
#   --target T:   builds only T and what it links (repeatable); default all.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)

cuda_mode=guard
targets=()
while (($#)); do
  case $1 in
    --cuda) cuda_mode=$2; shift 2 ;;
    --target) targets+=(--target "$2"); shift 2 ;;
    *) break ;;
  esac
done

nvcc=/usr/local/cuda/bin/nvcc
[[ -x $nvcc ]] || nvcc=$(command -v nvcc || true)
cuda=OFF why=""
driver() { [[ -r /proc/driver/nvidia/version ]] || ldconfig -p 2>/dev/null | grep -c 'libcuda\.so\.1' >/dev/null; }
arch=${CDSM_CUDA_ARCH:-90}
case $cuda_mode in
  guard)
    if [[ -n $nvcc ]]; then
      cuda=ON why="nvcc found ($nvcc): compiled as a guard, GPU or not"
      if [[ -z ${CDSM_CUDA_ARCH:-} ]] && ! driver; then
        arch=90-virtual why+="; no NVIDIA driver: PTX only (90-virtual), no machine code"
      fi
    else why="no nvcc"; fi
    echo "build: CUDA backend ${cuda,,}: $why" >&2 ;;
  auto)
    if [[ ${CDSM_CUDA:-} == 1 ]]; then
      [[ -n $nvcc ]] || { echo "build: CDSM_CUDA=1 but no nvcc (looked at /usr/local/cuda/bin and PATH)" >&2; exit 2; }
      cuda=ON why="asked for (CDSM_CUDA=1)"
    elif [[ ${CDSM_CUDA:-} == 0 ]]; then
      why="not asked for (CDSM_CUDA=0)"
    elif [[ -n $nvcc ]] && grep -qs '^CDSM_CUDA:BOOL=ON' build/CMakeCache.txt; then
      cuda=ON why="build/ is already configured with it (scripts/test.sh): kept, not rebuilt without it"
    elif [[ -z $nvcc ]]; then
      why="no nvcc (looked at /usr/local/cuda/bin and PATH)"
    elif driver; then
      cuda=ON why="nvcc and an NVIDIA driver found"
    else
      why="nvcc found but no NVIDIA driver (no /proc/driver/nvidia/version, no libcuda.so.1): nothing could run it; CDSM_CUDA=1 builds it anyway"
    fi
    echo "build: CUDA backend ${cuda,,}: $why" >&2 ;;
  on) [[ -n $nvcc ]] || { echo "build: --cuda on but no nvcc" >&2; exit 2; }; cuda=ON ;;
  off) ;;
  *) echo "build: --cuda takes guard, auto, on or off (got '$cuda_mode')" >&2; exit 2 ;;
esac

cuda_args=(-DCDSM_CUDA="$cuda")
if [[ $cuda == ON ]]; then
  # One real architecture keeps the build short; override with CDSM_CUDA_ARCH.
  cuda_args+=(-DCMAKE_CUDA_COMPILER="$nvcc" -DCMAKE_CUDA_ARCHITECTURES="$arch")
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "${cuda_args[@]}" "$@" >/dev/null
cmake --build build -j "$jobs" "${targets[@]}"
