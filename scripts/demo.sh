#!/usr/bin/env bash
# First command of the README: installs what the program needs, builds the
# `cdsm` program alone (the CUDA backend only where an NVIDIA driver could
# run it: scripts/build.sh --cuda auto says which and why), and renders the
# default scene to default.png, printing per-stage times, memory and the
# error against the exact reference renderer.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh program
# A first configure leaves the tests out (their packages are the test
# command's); a build/ that scripts/test.sh configured keeps them.
extra=()
[[ -f build/CMakeCache.txt ]] || extra=(-DCDSM_TESTS=OFF)
bash scripts/build.sh --cuda auto --target cdsm "${extra[@]}"
./build/cdsm render content/scenes/default.json -o default.png --compare-reference --stats default.stats.json
