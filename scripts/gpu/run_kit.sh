#!/usr/bin/env bash
# Runs on a GPU machine (docs/gpu.md), from the repository root, with the
# kit (scripts/gpu/prepare_kit.sh) carried in build-kit/: unpacks the kit's
# packages into build-kit/prefix (dpkg -x, never into /), configures the
# `gpu-parity` preset, builds the GPU tests and the benchmark, runs the tests
# labelled `gpu` (a missing device fails them here: CDSM_REQUIRE_GPU=1),
# compute-sanitizer memcheck and racecheck on a small case, and the
# benchmark, and writes everything to $OUT (the device tool's folder that
# comes back) or build-gpu-parity/kit-results.
#
# Usage: bash scripts/gpu/run_kit.sh [quick]   (quick: tests only, no benchmark or sanitizer)
set -uo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
out=${OUT:-$root/build-gpu-parity/kit-results}
mkdir -p "$out"
log="$out/kit.log"
exec > >(tee -a "$log") 2>&1
step() { echo "== $(date +%T) $*"; }
status=0

step "kit: unpacking build-kit/debs into build-kit/prefix"
export CDSM_KIT_PREFIX=$root/build-kit/prefix
mkdir -p "$CDSM_KIT_PREFIX"
for f in "$root"/build-kit/debs/*.deb; do dpkg -x "$f" "$CDSM_KIT_PREFIX" || { echo "cannot unpack $f"; exit 1; }; done
lib=$CDSM_KIT_PREFIX/usr/lib/x86_64-linux-gnu
export LD_LIBRARY_PATH=$lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export PKG_CONFIG=$CDSM_KIT_PREFIX/usr/bin/pkgconf
export PKG_CONFIG_LIBDIR=$lib/pkgconfig:$CDSM_KIT_PREFIX/usr/share/pkgconfig
export PKG_CONFIG_SYSROOT_DIR=$CDSM_KIT_PREFIX
# EGL on the NVIDIA driver through the kit's libglvnd.
for v in /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json /usr/share/glvnd/egl_vendor.d/10_nvidia.json; do
  [[ -f $v ]] && export __EGL_VENDOR_LIBRARY_FILENAMES=$v && break
done
export PATH=/usr/local/cuda/bin:$PATH
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || true
nvcc --version | tail -1; cmake --version | head -1

step "configure (preset gpu-parity)"
cmake --preset gpu-parity -DPKG_CONFIG_EXECUTABLE="$PKG_CONFIG" >"$out/configure.log" 2>&1 || {
  tail -40 "$out/configure.log"; exit 1; }
step "build"
jobs=$(nproc)
cmake --build build-gpu-parity -j "$jobs" --target test_cuda_backend test_exec_backend test_backend_choice bench_gpu \
  $(grep -q test_gl_interop build-gpu-parity/build.ninja && echo test_gl_interop) >"$out/build.log" 2>&1 || {
  tail -60 "$out/build.log"; exit 1; }

step "tests: label gpu, and the exec backend on this machine's CPU"
export CDSM_REQUIRE_GPU=1
(cd build-gpu-parity && ctest -L gpu --output-on-failure --timeout 900 -R "test_cuda_backend|test_gl_interop") || status=1
build-gpu-parity/tests/gpu/test_exec_backend --gtest_brief=1 || status=1
build-gpu-parity/tests/gpu/test_backend_choice --gtest_brief=1 || status=1
build-gpu-parity/tests/gpu/test_cuda_backend --gtest_output=json:"$out/test_cuda_backend.json" >/dev/null 2>&1 || true

if [[ "${1:-}" != quick ]]; then
  if command -v compute-sanitizer >/dev/null; then
    for tool in memcheck racecheck; do
      step "compute-sanitizer --tool $tool (one small case)"
      compute-sanitizer --tool $tool --error-exitcode 3 \
        build-gpu-parity/tests/gpu/test_cuda_backend --gtest_filter='CudaBackend.SpilledTexelsMatchTheBoundedBuffer:CudaBackend.StageTimesFromEvents' \
        >"$out/sanitizer-$tool.log" 2>&1 && echo "$tool: clean" || { echo "$tool: FAILED"; tail -30 "$out/sanitizer-$tool.log"; status=1; }
    done
  fi
  step "benchmark"
  build-gpu-parity/tests/gpu/bench_gpu --out "$out" --repeat 3 || status=1
fi
step "done (status $status); results in $out"
exit $status
