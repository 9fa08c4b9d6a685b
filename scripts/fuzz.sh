#!/usr/bin/env bash
# CI's fuzzing phase: the libFuzzer targets of tests/fuzz, from the sanitizer phase's build
# (scripts/sanitized-build.sh: clang, ASan + UBSan, coverage on every target; run alone, this
# builds only the targets), each run for SOILVOL_FUZZ_SECONDS (default 20) from the committed
# seeds plus those soilvol's encoders write. Any crash, leak, sanitizer finding or broken round
# trip fails the phase; the input that did it is kept in the build dir (crash-*, leak-*,
# timeout-*) for a regression test.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${SOILVOL_ASAN_BUILD_DIR:-build-asan}"
seconds="${SOILVOL_FUZZ_SECONDS:-20}"
targets=(fuzz_cloud_decoder fuzz_mesh_decoder fuzz_image_header fuzz_depth_scan fuzz_model_codec
    fuzz_http_binding fuzz_calibration_record fuzz_token_file fuzz_multipart fuzz_resource_rules
    fuzz_process_stats fuzz_production fuzz_webhook_url fuzz_alert_config)
scripts/sanitized-build.sh "${targets[@]}" fuzz_make_seeds
corpus="$build_dir/fuzz-corpus"
rm -rf "$corpus"
mkdir -p "$corpus"
cp -r tests/fuzz/corpus/. "$corpus/"
"$build_dir/tests/fuzz/fuzz_make_seeds" "$corpus"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Runs one target; its output goes to its log, printed when it ends.
fuzz_one() {
    local target="$1"
    mkdir -p "$corpus/$target"
    echo "--- $target: ${seconds} s from $(find "$corpus/$target" -type f | wc -l) seeds"
    # One process, 2 GB of address-space headroom per input; an input slower than 10 s is a
    # finding too (a hang).
    (cd "$build_dir" && "./tests/fuzz/$target" -max_total_time="$seconds" -rss_limit_mb=2048 \
        -timeout=10 -print_final_stats=1 "$PWD/fuzz-corpus/$target" 2>&1 | tail -n 12)
}
# One target per core at a time (each fuzzes on one thread): the same seconds per target in
# half the wall time on two cores.
logs="$build_dir/fuzz-logs"
rm -rf "$logs"
mkdir -p "$logs"
failed=0
running=0
for target in "${targets[@]}"; do
    if [ "$running" -ge "$(nproc)" ]; then
        wait -n || failed=1
        running=$((running - 1))
    fi
    fuzz_one "$target" >"$logs/$target.log" 2>&1 &
    running=$((running + 1))
done
while [ "$running" -gt 0 ]; do
    wait -n || failed=1
    running=$((running - 1))
done
for target in "${targets[@]}"; do cat "$logs/$target.log"; done
if [ "$failed" -ne 0 ]; then
    echo "fuzz: a target failed (its log above; the input is in $build_dir)" >&2
    exit 1
fi
