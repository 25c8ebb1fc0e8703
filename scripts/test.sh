#!/usr/bin/env bash
# Second command of the README: installs the dependencies, builds, and runs
# the whole test suite (ctest; GL tests headless through EGL, window tests
# under Xvfb), then the ASan+UBSan build of the core, loader and stability
# tests, then 60 s of each libFuzzer target (scripts/fuzz.sh; skip with
# CDSM_SKIP_FUZZ=1); with CDSM_TSAN=1 also the ThreadSanitizer build
# (scripts/tsan.sh, about 25 minutes more). Exits non-zero on any failure
# or fuzzer finding.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
jobs=$(nproc 2>/dev/null || echo 2)
echo "== ctest (build/)"
(cd build && xvfb-run -a -s "-screen 0 1280x1024x24" ctest --output-on-failure -j "$jobs" --timeout 900)

if [[ "${CDSM_SKIP_SANITIZERS:-0}" != 1 ]]; then
  echo "== ASan+UBSan build (build-asan/): core, loader and stability tests"
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" \
    -DCDSM_SANITIZE=ON -DCDSM_GL=OFF -DCDSM_CUDA=OFF -DCDSM_EDITOR=OFF >/dev/null
  cmake --build build-asan -j "$jobs"
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     ctest --output-on-failure -j "$jobs" -L 'unit|stability' -LE slow --timeout 900)
fi

if [[ "${CDSM_SKIP_FUZZ:-0}" != 1 ]]; then
  echo "== fuzzing (build-fuzz/, clang libFuzzer + ASan/UBSan/LSan): every target for 60 s"
  bash scripts/fuzz.sh all 60
fi

if [[ "${CDSM_TSAN:-0}" == 1 ]]; then
  bash scripts/tsan.sh
fi
