#!/usr/bin/env bash
# Generates the Python stubs of soilvol's API into OUT_DIR with Debian's protoc and
# grpc_python_plugin (protobuf-compiler, protobuf-compiler-grpc; no PyPI): soilvol.v1 and the
# google.rpc / google.api messages it uses (googleapis' .proto files from
# golang-github-gogo-googleapis-dev). Usage: generate.sh OUT_DIR; then PYTHONPATH=OUT_DIR.
set -euo pipefail
repo="$(cd "$(dirname "$0")/../../.." && pwd)"
out="$(mkdir -p "$1" && cd "$1" && pwd)"
googleapis="${SOILVOL_GOOGLEAPIS_PROTO_ROOT:-/usr/share/gocode/src/github.com/gogo/googleapis}"
protoc -I "$googleapis" -I "$repo/proto" --python_out="$out" --grpc_python_out="$out" \
    --plugin=protoc-gen-grpc_python="$(command -v grpc_python_plugin)" \
    "$repo/proto/soilvol/v1/soilvol.proto"
protoc -I "$googleapis" --python_out="$out" \
    "$googleapis/google/rpc/status.proto" "$googleapis/google/rpc/error_details.proto" \
    "$googleapis/google/api/annotations.proto" "$googleapis/google/api/http.proto"
echo "generated $out"
