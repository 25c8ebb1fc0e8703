#!/usr/bin/env bash
# ThreadSanitizer run of the cpu backend's tests (unit and stability labels,
# not the slow ones): builds build-tsan/ with -fsanitize=thread (GL, CUDA and
# the editor off) against oneTBB built with TBB_SANITIZE=thread, and fails on
# any report. Debian's libtbb is not instrumented: TSan cannot see its
# synchronization and reports races inside tbb::parallel_for that are not
# there, so the same oneTBB version is built from Debian's source package
# (once, cached in build-tsan/tbb-install/).
#   bash scripts/tsan.sh            # or CDSM_TSAN=1 bash scripts/test.sh
# About 25 minutes on 2 cores the first time (TBB, then the tree); the tests
# run 5-15x slower than in Release.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
build=build-tsan
tbb=$root/$build/tbb-install
mkdir -p "$build"

if [[ ! -f $tbb/lib/cmake/TBB/TBBConfig.cmake ]]; then
  version=$(dpkg-query -W -f '${source:Version}' libtbb-dev)  # e.g. 2021.8.0-2+deb12u1
  echo "== building oneTBB $version with TBB_SANITIZE=thread into $tbb"
  src=$root/$build/tbb-src
  rm -rf "$src" && mkdir -p "$src"
  if ! (cd "$src" && apt-get source --download-only "onetbb=$version" >/dev/null 2>&1); then
    # No deb-src entry on this machine: add one for Debian's archive.
    codename=$(. /etc/os-release && echo "$VERSION_CODENAME")
    printf 'Types: deb-src\nURIs: http://deb.debian.org/debian\nSuites: %s %s-updates\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' \
      "$codename" "$codename" >/etc/apt/sources.list.d/cdsm-tsan-debsrc.sources
    apt-get update -qq
    (cd "$src" && apt-get source --download-only "onetbb=$version" >/dev/null)
  fi
  tar -xf "$src"/onetbb_*.orig.tar.* -C "$src"
  cmake -S "$src"/oneTBB-* -B "$src/build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DTBB_SANITIZE=thread -DTBB_TEST=OFF -DTBB_EXAMPLES=OFF -DTBB_STRICT=OFF \
    -DCMAKE_INSTALL_PREFIX="$tbb" >/dev/null
  cmake --build "$src/build" -j "$jobs"
  cmake --install "$src/build" >/dev/null
fi

if [[ ! -f $build/build.ninja ]]; then
  echo "== configuring $build/ (-fsanitize=thread, TBB from $tbb)"
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS="-fsanitize=thread -O1 -g" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread -Wl,-rpath,$tbb/lib" \
    -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread" -DTBB_DIR="$tbb/lib/cmake/TBB" \
    -DCDSM_GL=OFF -DCDSM_CUDA=OFF -DCDSM_EDITOR=OFF -DCDSM_TEST_TIMEOUT_SCALE=15 >/dev/null
fi
cmake --build "$build" -j "$jobs"

echo "== ThreadSanitizer: unit and stability tests (cpu backend)"
# halt_on_error: the first report fails its test; second_deadlock_stack for
# readable lock reports. LD_LIBRARY_PATH puts the instrumented libtbb first
# for libraries that link it too (OpenVDB).
(cd "$build" && LD_LIBRARY_PATH="$tbb/lib" \
   TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:report_signal_unsafe=0" \
   ctest --output-on-failure -j "$jobs" -L 'unit|stability' -LE slow)
