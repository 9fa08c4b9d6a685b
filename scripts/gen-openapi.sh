#!/usr/bin/env bash
# Regenerates proto/openapi/soilvol.v1.openapi.json, the OpenAPI 3.0 document the server embeds
# and serves at GET /openapi.json:
#   1. Debian's protoc-gen-swagger (golang-grpc-gateway 1.x, json_names_for_fields=true: the
#      JSON names the server sends) writes Swagger 2.0 from the proto's google.api.http
#      annotations; it predates proto3 `optional`, so it reads a copy without the keyword.
#   2. scripts/openapi/to-openapi3.js converts it with swagger2openapi (npm, pinned in
#      scripts/install-test-tools.sh) and merges proto/openapi/routes.json (routes beside the
#      RPCs, bearer security, Status errors, uploads, Server-Sent Events).
# The build only embeds the committed file (no Node needed to build); CI runs this with --check
# (tests/integration/test_openapi_tools.py) and fails when the file differs from what it makes.
# Usage: scripts/gen-openapi.sh [--check]
set -euo pipefail
cd "$(dirname "$0")/.."

googleapis="${SOILVOL_GOOGLEAPIS_PROTO_ROOT:-/usr/share/gocode/src/github.com/gogo/googleapis}"
tools_dir="${SOILVOL_TOOLS_DIR:-$HOME/.cache/soilvol-tools}"
out=proto/openapi/soilvol.v1.openapi.json
if [ ! -d "$tools_dir/node_modules/swagger2openapi" ]; then
    echo "gen-openapi: swagger2openapi is not installed in $tools_dir (scripts/install-test-tools.sh)" >&2
    exit 1
fi
version=$(sed -n 's/^project(soilvol VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

mkdir -p "$work/in/soilvol/v1"
sed -E 's/^([[:space:]]*)optional /\1/' proto/soilvol/v1/soilvol.proto >"$work/in/soilvol/v1/soilvol.proto"
protoc -I"$googleapis" -I"$work/in" --plugin=protoc-gen-swagger="$(command -v protoc-gen-swagger)" \
    --swagger_out=logtostderr=true,json_names_for_fields=true:"$work" \
    "$work/in/soilvol/v1/soilvol.proto"
SOILVOL_TOOLS_DIR="$tools_dir" node scripts/openapi/to-openapi3.js \
    "$work/soilvol/v1/soilvol.swagger.json" proto/openapi/routes.json "$version" >"$work/openapi.json"

if [ "${1:-}" = "--check" ]; then
    if ! diff -u "$out" "$work/openapi.json" >"$work/diff"; then
        head -n 60 "$work/diff" >&2
        echo "gen-openapi: $out is not what the proto and routes.json make: run scripts/gen-openapi.sh and commit it" >&2
        exit 1
    fi
    echo "gen-openapi: $out is up to date"
    exit 0
fi
cp "$work/openapi.json" "$out"
echo "gen-openapi: wrote $out"
