#!/usr/bin/env bash
# One instrumented build for CI's sanitizer and fuzzing phases: clang, AddressSanitizer +
# UndefinedBehaviorSanitizer on every target (any finding aborts) and libFuzzer's coverage
# instrumentation (-DSOILVOL_FUZZ=ON), so that the unit tests, the integration suites' server
# and the fuzz targets come from the same objects, compiled once. -O1, as the sanitizers'
# manuals advise. Arguments: the targets to build (none: all). Build dir
# ${SOILVOL_ASAN_BUILD_DIR:-build-asan}.
# Measured on the CI's two cores: clang compiles these files 22-32% faster than GCC, and the
# separate clang build the fuzzing phase used to make (about 300 s) is gone. lld links the
# instrumented executables (large: coverage and debug lines) faster than GNU ld.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh fuzz
build_dir="${SOILVOL_ASAN_BUILD_DIR:-build-asan}"
CC=clang CXX=clang++ cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DSOILVOL_SANITIZE=address,undefined \
    -DSOILVOL_FUZZ=ON -DSOILVOL_BUILD_BENCHMARKS=OFF -DSOILVOL_WARNINGS_AS_ERRORS=ON \
    -DCMAKE_EXE_LINKER_FLAGS=-fuse-ld=lld >/dev/null
if [ "$#" -gt 0 ]; then
    cmake --build "$build_dir" -j "$(nproc)" --target "$@"
else
    cmake --build "$build_dir" -j "$(nproc)"
fi
