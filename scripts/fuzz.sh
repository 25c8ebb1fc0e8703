#!/usr/bin/env bash
# Runs the libFuzzer targets of tests/fuzz (clang, ASan+UBSan, LSan on).
#   bash scripts/fuzz.sh TARGET SECONDS [extra libFuzzer args]
#   bash scripts/fuzz.sh all SECONDS [extra libFuzzer args]   # every target
# Configures build-san/ when needed (scripts/configure-san.sh: the same
# clang ASan+UBSan build the test command's sanitizer tests use), builds the
# fuzz targets, then runs each target (as many at a time as there are
# cores) on a
# copy of tests/fuzz/corpus/TARGET/ in build-san/fuzz-work/TARGET/ (the
# checked-in corpus is never modified; new inputs and any crash, leak,
# timeout or OOM reproducer land there). Prints the final stats; exits
# non-zero on any finding.
set -euo pipefail
cd "$(dirname "$0")/.."

if (($# < 2)) || ! [[ $2 =~ ^[0-9]+$ ]]; then
  echo "usage: $0 TARGET|all SECONDS [extra libFuzzer args]" >&2
  exit 2
fi
target=$1 seconds=$2
shift 2

bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)
build=build-san
bash scripts/configure-san.sh
read -r -a all_targets <"$build/fuzz_targets.txt"
build_args=()
for t in "${all_targets[@]}"; do build_args+=(--target "$t"); done
cmake --build "$build" -j "$jobs" "${build_args[@]}"

if [[ $target == all ]]; then
  targets=("${all_targets[@]}")
elif [[ " ${all_targets[*]} " == *" $target "* ]]; then
  targets=("$target")
else
  echo "fuzz: unknown target '$target' (this build has: ${all_targets[*]})" >&2
  exit 2
fi

supp=$PWD/tests/fuzz/lsan.supp
# One target: its summary goes to $work/summary.txt, its exit status says
# whether it found something.
run_one() {
  local t=$1 work=$build/fuzz-work/$1
  rm -rf "$work"
  mkdir -p "$work/corpus" "$work/artifacts"
  cp -R "tests/fuzz/corpus/$t/." "$work/corpus/"
  # The largest input a loader accepts is bounded work, not a finding: a
  # 16 KiB .vdb whose tiles are just under the loader's limit (2^25 voxels,
  # 2026-12-03) loads in 0.8 s in Release and 19 s in this -O1 ASan build.
  # A unit over 60 s (2.5x that, with every core busy) is a finding: a
  # timeout reproducer; slower ones than that are not reported as "slow".
  local args=(-max_total_time="$seconds" -timeout=60 -report_slow_units=60 -rss_limit_mb=2048 -print_final_stats=1
              -artifact_prefix="$work/artifacts/")
  [[ -f tests/fuzz/$t.dict ]] && args+=(-dict="tests/fuzz/$t.dict")
  local asan=detect_leaks=1:symbolize=1
  # OpenVDB's readers run in a library without frame pointers: only the
  # slow unwinder puts their callers on a leak's stack (lsan.supp names one).
  [[ $t == fuzz_vdb ]] && asan+=:fast_unwind_on_malloc=0
  local rc=0
  ASAN_OPTIONS=$asan \
  LSAN_OPTIONS=suppressions=$supp:print_suppressions=0 \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "$build/tests/fuzz/$t" "${args[@]}" "${extra[@]}" "$work/corpus" >"$work/log.txt" 2>&1 || rc=$?
  local findings
  findings=$(ls "$work/artifacts")
  {
    echo "== $t: ${seconds}s on a copy of tests/fuzz/corpus/$t; log: $work/log.txt"
    # Final stats: the last status line (cov: ft: corp:) and libFuzzer's stat:: lines.
    grep -E '^#[0-9]+' "$work/log.txt" | tail -n 1 || true
    grep -E '^stat::' "$work/log.txt" || true
    echo "corpus: $(ls "$work/corpus" | wc -l) files, $(($(cat "$work/corpus"/* 2>/dev/null | wc -c) / 1024)) KiB"
    if ((rc != 0)) || [[ -n $findings ]]; then
      echo "== $t: FINDING (exit $rc); reproducers in $work/artifacts/: ${findings:-none}"
      grep -n -m 1 -E 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error|SUMMARY' "$work/log.txt" || true
      tail -n 60 "$work/log.txt"
    else
      echo "== $t: no findings"
    fi
  } >"$work/summary.txt"
  ((rc == 0)) && [[ -z $findings ]]
}

# As many targets at a time as there are cores, each for SECONDS.
extra=("$@")
failed=()
pending=("${targets[@]}")
running=()
report() {  # waits for the oldest running target
  local t=${running[0]}
  running=("${running[@]:1}")
  local ok=0
  wait "${pids[$t]}" || ok=1
  cat "$build/fuzz-work/$t/summary.txt"
  ((ok == 0)) || failed+=("$t")
}
declare -A pids
for t in "${pending[@]}"; do
  ((${#running[@]} >= jobs)) && report
  echo "== starting $t"
  run_one "$t" &
  pids[$t]=$!
  running+=("$t")
done
while ((${#running[@]})); do report; done

if ((${#failed[@]})); then
  echo "fuzz: findings in ${failed[*]}" >&2
  exit 1
fi
