#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs the demo on simulated scenes: an
# empty bucket is scanned and registered, then filled scans are measured against the truth; then
# the same from rendered stereo pairs (calibrated from rendered chessboards).
# `scripts/run.sh bench` instead reproduces the paper's tables into BENCHMARK.md.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
bench="${SOILVOL_BUILD_DIR:-build}/bench/soilvol-bench"
if [ "${1:-demo}" = "bench" ]; then
    exec "$bench" all --out BENCHMARK.md
fi
"$bench" demo
echo
exec "$bench" stereo-demo
