#!/usr/bin/env bash
# Builds the Go example offline from Debian's packages (golang-go, golang-google-grpc-dev,
# golang-google-genproto-dev, golang-google-protobuf-dev, golang-github-golang-protobuf-1-5-dev,
# protoc-gen-go, protoc-gen-go-grpc):
# GOPATH mode over /usr/share/gocode, the stubs generated into OUT/src/soilvol.dev/api.
# Usage: client/examples/go/build.sh OUT_DIR  ->  OUT_DIR/soilvol-go-example
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$here/../../.."
out="$(mkdir -p "$1" && cd "$1" && pwd)"
googleapis="${SOILVOL_GOOGLEAPIS_PROTO_ROOT:-/usr/share/gocode/src/github.com/gogo/googleapis}"
gen="$out/src/soilvol.dev/api/soilvol/v1"
mkdir -p "$gen" "$out/src/soilvol.dev/example"
maps="Mgoogle/api/annotations.proto=google.golang.org/genproto/googleapis/api/annotations"
maps+=",Mgoogle/api/http.proto=google.golang.org/genproto/googleapis/api/annotations"
maps+=",Mgoogle/rpc/status.proto=google.golang.org/genproto/googleapis/rpc/status"
protoc -I "$googleapis" -I "$repo/proto" \
    --go_out="$maps:$out/src" --go-grpc_out="$maps:$out/src" \
    "$repo/proto/soilvol/v1/soilvol.proto"
cp "$here/main.go" "$out/src/soilvol.dev/example/main.go"
cd "$out/src/soilvol.dev/example"
GO111MODULE=off GOPATH="$out:/usr/share/gocode" GOFLAGS='' GOCACHE="$out/cache" \
    go build -o "$out/soilvol-go-example" .
echo "built $out/soilvol-go-example"
