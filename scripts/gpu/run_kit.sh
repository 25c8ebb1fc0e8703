#!/usr/bin/env bash
# Runs on a GPU machine (docs/gpu.md), from the repository root, with the kit
# scripts/gpu/build_kit.sh made here carried along in gpu-kit/. Compiles
# nothing: the binaries are the kit's, their libraries the kit's (through
# LD_LIBRARY_PATH, for them only) and the driver's. Stages, in order, each
# with its own time limit inside a total of $CDSM_KIT_BUDGET_S (default 540 s,
# so the whole run stays under 9 minutes; run it with timeout_s 590):
#
#   tests       test_cuda_backend, test_gl_interop and (after every other
#               stage: its fault breaks the device's GL) test_cuda_faults (a
#               kernel faulting on purpose) of the parity build, once each,
#               with CDSM_REQUIRE_GPU=1 and CDSM_REQUIRE_GL=1 (a missing
#               device, a GL context off the device or any skip fails them);
#   gl          the GL suite (test_fragment_raster; test_gl_kit_suite:
#               test_gl_default_scene, test_gl_system and test_gpu_mesh in
#               one binary) on the device's own OpenGL;
#   sanitizers  compute-sanitizer memcheck and initcheck on one small case;
#   bench       bench_gpu (release build): per-stage times at 1280x720 and
#               1920x1080, GL against CUDA fragments, the CPU/CUDA ratio;
#               bench_warm --backend cuda: the warm frames of an engine
#               (bench_warm.txt), 100 frames per scenario at 1920x1080.
#
# Every figure goes into $OUT/results.json (each stage's exit code, seconds
# and output tail; the tests' GoogleTest JSON; the sanitizers' error counts;
# the benchmark's JSON; the device); beside it kit.log (this output),
# bench_gpu.md and the two sanitizer logs. $OUT is the device tool's folder
# that comes back (at most 8 files); elsewhere gpu-kit-results/.
#
# Usage: bash scripts/gpu/run_kit.sh [tests] [gl] [sanitizers] [bench]   (default: all four)
set -uo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
kit=$root/${CDSM_KIT_DIR:-gpu-kit}
out=${OUT:-$root/gpu-kit-results}
work=$(mktemp -d)
mkdir -p "$out"
exec > >(tee -a "$out/kit.log") 2>&1
budget=${CDSM_KIT_BUDGET_S:-540}
stages=("$@")
((${#stages[@]})) || stages=(tests gl sanitizers bench)
wants() { [[ " ${stages[*]} " == *" $1 "* ]]; }
step() { echo "== $(date +%T) +$SECONDS s: $*"; }

# ---- preflight ----------------------------------------------------------------
[[ -f $kit/manifest.json ]] || { echo "run_kit: no $kit/manifest.json: carry the kit (scripts/gpu/build_kit.sh; run(carry: [\"gpu-kit\"]))"; exit 2; }
manifest_get() { sed -n "s/.*\"$1\": \"\([^\"]*\)\".*/\1/p" "$kit/manifest.json" | head -1; }
step "kit of commit $(manifest_get commit), built $(manifest_get built) in $(manifest_get source_dir)"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1 | head -2
echo "glibc here: $(ldd --version 2>/dev/null | head -1 | grep -o '[0-9.]*$'); the kit needs $(manifest_get needs_glibc) (libstdc++ symbols up to GLIBCXX_$(manifest_get needs_glibcxx))"
command -v compute-sanitizer >/dev/null || for d in /usr/local/cuda/bin /usr/local/cuda/compute-sanitizer; do
  [[ -x $d/compute-sanitizer ]] && PATH=$d:$PATH && break
done

# The binaries were built in source_dir: the tests read content/ and
# tests/gpu/scenes/ there. Where this tree lies elsewhere, that path points here.
built_in=$(manifest_get source_dir)
if [[ -n $built_in && $(readlink -f "$built_in" 2>/dev/null) != "$(readlink -f "$root")" ]]; then
  if [[ -e $built_in ]]; then
    echo "run_kit: $built_in exists and is not this tree: the tests would read its content/"
  else
    mkdir -p "$(dirname "$built_in")" && ln -s "$root" "$built_in" && echo "linked $built_in -> $root"
  fi
fi
mkdir -p "$root/$(sed -n 's/.*"parity": "\([^"]*\)".*/\1/p' "$kit/manifest.json")/test-output" 2>/dev/null

# The kit's libraries for its binaries only; then the driver's (libcuda,
# the EGL vendor library) wherever this machine keeps them.
libs=$kit/root/usr/lib/x86_64-linux-gnu:$kit/root/lib/x86_64-linux-gnu
for d in /usr/local/nvidia/lib64 /usr/local/nvidia/lib /usr/lib/x86_64-linux-gnu; do
  [[ -d $d ]] && libs=$libs:$d
done
for v in /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json /usr/share/glvnd/egl_vendor.d/10_nvidia.json \
  /etc/glvnd/egl_vendor.d/10_nvidia.json; do
  [[ -f $v ]] && export __EGL_VENDOR_LIBRARY_FILENAMES=$v && break
done
echo "EGL vendor file: ${__EGL_VENDOR_LIBRARY_FILENAMES:-none found: the default folders of the loader}"
export CDSM_CONTENT_DIR=$root/content
kit_env=(env "LD_LIBRARY_PATH=$libs" CDSM_REQUIRE_GPU=1 CDSM_REQUIRE_GL=1)
LD_LIBRARY_PATH=$libs ldd "$kit/bin/parity/test_cuda_backend" | grep -E "not found|=> /" | sed 's/^/  /'

# ---- stages ---------------------------------------------------------------------
declare -A code secs
order=()
# run NAME LIMIT_S LOG COMMAND...: within what is left of the budget.
run() {
  local name=$1 limit=$2 log=$3 t0=$SECONDS left
  shift 3
  left=$((budget - SECONDS))
  ((left < limit)) && limit=$left
  order+=("$name")
  if ((limit < 20)); then
    echo "$name: not run, ${left} s of the budget left" | tee "$log"
    code[$name]=124
    secs[$name]=0
    return
  fi
  step "$name (limit $limit s)"
  timeout -k 10 "$limit" "$@" >"$log" 2>&1
  code[$name]=$?
  secs[$name]=$((SECONDS - t0))
  tail -15 "$log"
  echo "-- $name: exit ${code[$name]} after ${secs[$name]} s"
}

if wants tests; then
  run test_cuda_backend 200 "$work/test_cuda_backend.log" "${kit_env[@]}" CDSM_CUDA_SYNC=0 \
    "$kit/bin/parity/test_cuda_backend" --gtest_output=json:"$work/test_cuda_backend.json"
  run test_gl_interop 60 "$work/test_gl_interop.log" "${kit_env[@]}" \
    "$kit/bin/parity/test_gl_interop" --gtest_output=json:"$work/test_gl_interop.json"
fi
if wants gl; then
  # The GL suite on the device's OpenGL (CI runs it on Mesa llvmpipe only).
  # test_gl_system's part reads one glTF of the shared data, which the kit
  # carries (data/). test_gpu_mesh's: the waving curtain read where it is
  # (on a CUDA device, through the cuda backend's lists_from_gl).
  for t in test_fragment_raster test_gl_kit_suite; do
    run "$t" 120 "$work/$t.log" "${kit_env[@]}" "CDSM_DATA_DIR=$kit/data" "$kit/bin/parity/$t" \
      --gtest_output=json:"$work/$t.json"
  done
fi
if wants sanitizers; then
  small='CudaBackend.StageTimesFromEvents'  # the default scene, 128^2 maps, 160x120: every kernel once
  for tool in memcheck initcheck; do
    if command -v compute-sanitizer >/dev/null; then
      run "$tool" 75 "$out/sanitizer-$tool.log" "${kit_env[@]}" CDSM_CUDA_SYNC=1 \
        compute-sanitizer --tool "$tool" --error-exitcode 3 --print-limit 50 \
        "$kit/bin/parity/test_cuda_backend" --gtest_filter="$small"
    else
      echo "compute-sanitizer: not found" >"$out/sanitizer-$tool.log"
      order+=("$tool") && code[$tool]=127 && secs[$tool]=0
    fi
  done
fi
if wants bench; then
  run bench_gpu 240 "$work/bench_gpu.log" env "LD_LIBRARY_PATH=$libs" \
    "$kit/bin/bench_gpu" --out "$work/bench" --repeat 3 --scene "$root/content/scenes/default.json"
  [[ -f $work/bench/bench_gpu.md ]] && cp "$work/bench/bench_gpu.md" "$out/"
  # The warm frames an engine runs (update() + bind_gl() on its context, GL
  # fragments handed to CUDA), the scenarios bench_warm runs on CPU threads.
  run bench_warm 150 "$out/bench_warm.txt" env "LD_LIBRARY_PATH=$libs" "CDSM_CONTENT_DIR=$root/content" \
    "$kit/bin/bench_warm" --backend cuda --frames 100
fi

# Last of all, after every other stage: a kernel that faults on purpose. Its
# MMU fault (Xid 31) leaves the device's graphics engine broken for every
# later process until the GPU is reset (measured 2026-12-04 on an H200: the
# GL rasterizer passed all its tests before it and returned garbage counts
# after it), so nothing may run on the machine after this test.
if wants tests; then
  run test_cuda_faults 30 "$work/test_cuda_faults.log" "${kit_env[@]}" \
    "$kit/bin/parity/test_cuda_faults" --gtest_filter='CudaFaultsOnDevice.*' --gtest_output=json:"$work/test_cuda_faults.json"
fi

# ---- results.json -----------------------------------------------------------------
step "results"
status=0
for s in "${order[@]}"; do [[ ${code[$s]} == 0 ]] || status=1; done
{
  echo "{"
  echo "  \"kit\": $(cat "$kit/manifest.json" | sed '2,$s/^/  /'),"
  printf '  "device": "%s",\n' "$(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null | head -1 | sed 's/"/\\"/g')"
  echo "  \"budget_s\": $budget, \"total_s\": $SECONDS, \"status\": $status,"
  echo "  \"stages\": {"
  first=1
  for s in "${order[@]}"; do
    ((first)) || echo ","
    first=0
    log=$work/$s.log
    [[ $s == memcheck || $s == initcheck ]] && log=$out/sanitizer-$s.log
    errors=null
    [[ $s == memcheck || $s == initcheck ]] &&
      errors=$(grep -o 'ERROR SUMMARY: [0-9]*' "$log" 2>/dev/null | grep -o '[0-9]*$' | tail -1)
    printf '    "%s": {"exit": %s, "seconds": %s, "sanitizer_errors": %s, "tail": "%s"' "$s" "${code[$s]}" "${secs[$s]}" \
      "${errors:-null}" "$(tail -c 3000 "$log" 2>/dev/null | sed 's/\\/\\\\/g; s/"/\\"/g; s/\t/ /g' | tr -d '\000-\010\013-\037' | sed ':a;N;$!ba;s/\n/\\n/g')"
    for j in "$work/$s.json" "$work/bench/bench_gpu.json"; do
      [[ $j == "$work/bench/bench_gpu.json" && $s != bench_gpu ]] && continue
      [[ -s $j ]] && printf ', "json": %s' "$(cat "$j")"
    done
    printf '}'
  done
  echo
  echo "  }"
  echo "}"
} >"$out/results.json"
if command -v python3 >/dev/null && ! python3 -c 'import json,sys; json.load(open(sys.argv[1]))' "$out/results.json" 2>/dev/null; then
  echo "run_kit: results.json does not parse (kept as written)"
fi
rm -rf "$work"
step "done: status $status; $(ls "$out" | tr '\n' ' ')"
exit $status
