#!/usr/bin/env bash
# Installs the optional tools of the integration tests: buf (npm @bufbuild/buf), for
# tests/integration/test_buf.py, into ${SOILVOL_TOOLS_DIR:-$HOME/.cache/soilvol-tools}.
# Idempotent. Always exits 0: without npm or the npm registry it prints a warning, and the buf
# test skips itself.
set -uo pipefail

tools_dir="${SOILVOL_TOOLS_DIR:-$HOME/.cache/soilvol-tools}"
buf_version="${SOILVOL_BUF_VERSION:-1.75.0}"
buf="$tools_dir/node_modules/.bin/buf"

warn() { echo "install-test-tools: warning: $*; test_buf.py will be skipped" >&2; }

if [ -x "$buf" ] && installed="$("$buf" --version 2>/dev/null)" && [ "$installed" = "$buf_version" ]; then
    echo "install-test-tools: buf $installed already in $tools_dir"
    exit 0
fi
if ! command -v npm >/dev/null 2>&1; then
    warn "npm is not installed (apt-get install npm)"
    exit 0
fi
if ! mkdir -p "$tools_dir"; then
    warn "cannot create $tools_dir"
    exit 0
fi
echo "install-test-tools: installing @bufbuild/buf@$buf_version into $tools_dir"
if ! timeout 600 npm install --prefix "$tools_dir" --no-audit --no-fund --no-save \
        --fetch-retries 1 --fetch-timeout 60000 "@bufbuild/buf@$buf_version" >/dev/null; then
    warn "npm install @bufbuild/buf@$buf_version failed (is the npm registry reachable?)"
    exit 0
fi
if ! installed="$("$buf" --version 2>/dev/null)"; then
    warn "$buf was installed but does not run"
    exit 0
fi
echo "install-test-tools: buf $installed installed in $tools_dir"
