#!/usr/bin/env bash
# Configures build-san/ once: clang-14, -O1 with line tables only (file:line in
# every report at a tenth less compile than -g), ASan+UBSan, libFuzzer's
# coverage on the libraries. One build serves both the sanitizer tests (the
# core, loader and stability tests: GL, CUDA and the editor off) and every
# libFuzzer target (scripts/fuzz.sh). Does nothing when build-san/ exists.
set -euo pipefail
cd "$(dirname "$0")/.."
build=build-san
if [[ ! -f $build/build.ninja ]]; then
  echo "== configuring $build/ (clang-14, ASan+UBSan, libFuzzer coverage; tests and fuzz targets)"
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -gline-tables-only" \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 -DCDSM_SANITIZE=ON -DCDSM_FUZZ=ON \
    -DCDSM_GL=OFF -DCDSM_CUDA=OFF -DCDSM_EDITOR=OFF -DCDSM_TESTS=ON >/dev/null
fi
