#!/usr/bin/env bash
# Configures and builds the project into build/ (Release). CUDA is built
# when nvcc is found (a compile guard here; the backend runs where a GPU is).
# Usage: scripts/build.sh [extra cmake args...]
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
cuda_args=()
if [[ -x /usr/local/cuda/bin/nvcc ]]; then
  # One real architecture keeps the guard build short; override with CMAKE_CUDA_ARCHITECTURES.
  cuda_args=(-DCDSM_CUDA=ON -DCMAKE_CUDA_COMPILER=/usr/local/cuda/bin/nvcc -DCMAKE_CUDA_ARCHITECTURES="${CDSM_CUDA_ARCH:-90}")
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "${cuda_args[@]}" "$@" >/dev/null
cmake --build build -j "$jobs"
