#!/usr/bin/env bash
# Installs the npm tools of the tests and static checks into
# ${SOILVOL_TOOLS_DIR:-$HOME/.cache/soilvol-tools}, pinned:
#   @bufbuild/buf      tests/integration/test_buf.py (gRPC through server reflection)
#   dockerfile-utils   docker/Dockerfile lint            (scripts/check-static.sh)
#   dclint             docker/compose.yaml schema + lint (scripts/check-static.sh)
#   kubernetes-models  deploy/ schema validation         (tests/ship/check-deploy.sh)
#   yaml               YAML parser of tests/ship/validate_k8s.js
#   swagger2openapi    Swagger 2.0 -> OpenAPI 3.0 (scripts/gen-openapi.sh, the drift check)
#   @apidevtools/swagger-parser  independent OpenAPI validator   (tests/integration/test_openapi_tools.py)
#   openapi-typescript, openapi-fetch, typescript, @types/node  a client generated from /openapi.json and
#                      run against a live server                 (tests/integration/test_openapi_tools.py)
# Idempotent. Exits 0 without npm or the registry (a warning; test_buf.py skips itself), unless
# SOILVOL_REQUIRE_TOOLS=1 (CI), where a missing tool is an error.
set -uo pipefail

tools_dir="${SOILVOL_TOOLS_DIR:-$HOME/.cache/soilvol-tools}"
stamp="$tools_dir/installed.txt"
packages=(
    "@bufbuild/buf@${SOILVOL_BUF_VERSION:-1.75.0}"
    "dockerfile-utils@0.16.3"
    "dclint@3.1.0"
    "kubernetes-models@4.5.1"
    "yaml@2.9.1"
    "swagger2openapi@7.0.8"
    "@apidevtools/swagger-parser@12.1.0"
    "openapi-typescript@7.13.0"
    "openapi-fetch@0.17.0"
    "typescript@5.9.3"
    "@types/node@20.9.5"
)
wanted="${packages[*]}"

fail() {
    if [ "${SOILVOL_REQUIRE_TOOLS:-0}" = "1" ]; then
        echo "install-test-tools: error: $*" >&2
        exit 1
    fi
    echo "install-test-tools: warning: $*; the tests that need them skip themselves" >&2
    exit 0
}

if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$wanted" ] && [ -x "$tools_dir/node_modules/.bin/buf" ] &&
    [ -x "$tools_dir/node_modules/.bin/openapi-typescript" ] && [ -x "$tools_dir/node_modules/.bin/tsc" ]; then
    echo "install-test-tools: $wanted already in $tools_dir"
    exit 0
fi
command -v npm >/dev/null 2>&1 || fail "npm is not installed (Node.js with npm)"
mkdir -p "$tools_dir" || fail "cannot create $tools_dir"
echo "install-test-tools: installing $wanted into $tools_dir"
if ! timeout 600 npm install --prefix "$tools_dir" --no-audit --no-fund --no-save \
        --fetch-retries 1 --fetch-timeout 60000 "${packages[@]}" >/dev/null; then
    fail "npm install failed (is the npm registry reachable?)"
fi
"$tools_dir/node_modules/.bin/buf" --version >/dev/null 2>&1 || fail "buf was installed but does not run"
for bin in openapi-typescript tsc; do
    "$tools_dir/node_modules/.bin/$bin" --version >/dev/null 2>&1 || fail "$bin was installed but does not run"
done
echo "$wanted" >"$stamp"
echo "install-test-tools: installed in $tools_dir"
