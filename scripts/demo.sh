#!/usr/bin/env bash
# First command of the README: installs the dependencies, builds, and renders
# the default scene to default.png, printing per-stage times, memory and the
# error against the exact reference renderer.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
./build/cdsm render content/scenes/default.json -o default.png --compare-reference --stats default.stats.json
