#!/usr/bin/env bash
# Second command of the README: installs the dependencies, builds, and runs
# the whole test suite, stage by stage, printing each stage's time at the end:
#   install   Debian packages (scripts/install-deps.sh)
#   build     build/ (Release; CUDA compiled as a guard where nvcc is)
#   ctest     every test in build/ (GL tests headless through EGL, window
#             tests under Xvfb), the `slow` label included
#   san-build build-san/ (clang, ASan+UBSan, libFuzzer coverage): the core,
#             loader and stability tests and every fuzz target, one build
#   san-tests the unit and stability tests under ASan+UBSan (not `slow`)
#   fuzz      every libFuzzer target for 60 s (scripts/fuzz.sh)
# CDSM_SKIP_SANITIZERS=1 / CDSM_SKIP_FUZZ=1 skip the sanitizer stages / the
# fuzzing; CDSM_TSAN=1 adds the ThreadSanitizer build (scripts/tsan.sh,
# about 25 minutes more). Exits non-zero on any failure or fuzzer finding.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)

stages=()
stage_start=0
begin() { echo "== $1"; stage_name=$1; stage_start=$SECONDS; }
end() { stages+=("$(printf '%-10s %5d s' "$stage_name" $((SECONDS - stage_start)))"); }
summary() {
  echo "== stage times (total $((SECONDS)) s)"
  printf '  %s\n' "${stages[@]}"
}
trap summary EXIT

begin install; bash scripts/install-deps.sh; end
begin build; bash scripts/build.sh --cuda guard -DCDSM_TESTS=ON; end
begin ctest
(cd build && xvfb-run -a -s "-screen 0 1280x1024x24" ctest --output-on-failure -j "$jobs" --timeout 900)
end

if [[ "${CDSM_SKIP_SANITIZERS:-0}" != 1 || "${CDSM_SKIP_FUZZ:-0}" != 1 ]]; then
  begin san-build
  bash scripts/configure-san.sh
  cmake --build build-san -j "$jobs"
  end
fi

if [[ "${CDSM_SKIP_SANITIZERS:-0}" != 1 ]]; then
  begin san-tests
  (cd build-san && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     ctest --output-on-failure -j "$jobs" -L 'unit|stability' -LE slow --timeout 900)
  end
fi

if [[ "${CDSM_SKIP_FUZZ:-0}" != 1 ]]; then
  begin fuzz
  bash scripts/fuzz.sh all 60
  end
fi

if [[ "${CDSM_TSAN:-0}" == 1 ]]; then
  begin tsan; bash scripts/tsan.sh; end
fi
