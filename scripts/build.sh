#!/usr/bin/env bash
# Configures and builds soilvol (Release) into ${SOILVOL_BUILD_DIR:-build}. Warnings are errors
# when CI=true. Extra arguments go to CMake.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${SOILVOL_BUILD_DIR:-build}"
werror=OFF
if [ "${CI:-}" = "true" ]; then werror=ON; fi
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE="${SOILVOL_BUILD_TYPE:-Release}" \
    -DSOILVOL_WARNINGS_AS_ERRORS="$werror" "$@" >/dev/null
cmake --build "$build_dir" -j "$(nproc)"
