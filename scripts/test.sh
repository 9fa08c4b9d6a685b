#!/usr/bin/env bash
# The test command: installs what is missing (Debian packages; buf from npm for the reflection
# test), builds, runs every test: unit suites and the integration suites that start real
# servers (tests/integration).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh test
scripts/install-test-tools.sh
scripts/build.sh
ctest --test-dir "${SOILVOL_BUILD_DIR:-build}" --output-on-failure -j "$(nproc)"
