#!/usr/bin/env bash
# Second CI build: every target with AddressSanitizer + UndefinedBehaviorSanitizer (any finding
# aborts), then the test suite, unit and integration (the servers the integration tests start
# are instrumented too). Build dir ${SOILVOL_ASAN_BUILD_DIR:-build-asan}.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${SOILVOL_ASAN_BUILD_DIR:-build-asan}"
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1" -DSOILVOL_SANITIZE=address,undefined \
    -DSOILVOL_BUILD_BENCHMARKS=OFF -DSOILVOL_WARNINGS_AS_ERRORS=ON "$@" >/dev/null
cmake --build "$build_dir" -j "$(nproc)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp:print_suppressions=0"
# Left out here, run by the Release phase: the suites again against one external server (the
# same server code as the suites' own servers, only driven from outside) and the ship checks
# (docker/ and deploy/ files against the flags): they add a quarter of this phase's time and no
# code path the other tests do not run instrumented.
ctest --test-dir "$build_dir" --output-on-failure -j "$(nproc)" --timeout 1800 \
    -E '^(integration\.external_server.*|ship\..*)$'
