#!/usr/bin/env bash
# The API's static checks with buf (npm @bufbuild/buf, scripts/install-test-tools.sh):
#   lint      proto/ against buf.yaml (STANDARD; the exceptions are documented there)
#   breaking  proto/ against the base: the latest release tag v*, or until there is one the
#             merge base with main (origin/main when there is one); on main itself, the
#             previous commit, so that each change on main is checked against the one before.
# buf cannot fetch googleapis here (no Buf Schema Registry offline): protoc builds an image with
# the imports from Debian's golang-github-gogo-googleapis-dev, and buf checks the image.
# Usage: scripts/check-proto.sh [--image OUT.binpb] (only build the image of the working tree)
set -euo pipefail
cd "$(dirname "$0")/.."

googleapis="${SOILVOL_GOOGLEAPIS_PROTO_ROOT:-/usr/share/gocode/src/github.com/gogo/googleapis}"
tools_dir="${SOILVOL_TOOLS_DIR:-$HOME/.cache/soilvol-tools}"
buf="${SOILVOL_BUF:-$tools_dir/node_modules/.bin/buf}"
api=soilvol/v1/soilvol.proto

image() {  # image <proto root> <out.binpb>
    protoc --include_imports --include_source_info -I "$googleapis" -I "$1" -o "$2" "$1/$api"
}

if [ "${1:-}" = "--image" ]; then
    image proto "$2"
    exit 0
fi
if [ ! -x "$buf" ]; then
    echo "check-proto: buf is not installed (scripts/install-test-tools.sh)" >&2
    exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

image proto "$work/head.binpb"
"$buf" lint "$work/head.binpb" --path "$api" --config buf.yaml
echo "check-proto: buf lint clean (exceptions in buf.yaml)"

base=$(git describe --tags --abbrev=0 --match 'v*' 2>/dev/null || true)
if [ -z "$base" ]; then
    main=main
    git rev-parse --verify -q origin/main >/dev/null && main=origin/main
    base=$(git merge-base HEAD "$main" 2>/dev/null || true)
    if [ -z "$base" ] || [ "$base" = "$(git rev-parse HEAD)" ]; then
        base=$(git rev-parse -q --verify HEAD~1 || true)
    fi
fi
if [ -z "$base" ] || ! git cat-file -e "$base:proto/$api" 2>/dev/null; then
    echo "check-proto: no earlier proto to compare with; breaking check skipped"
    exit 0
fi
mkdir -p "$work/base/$(dirname "$api")"
git show "$base:proto/$api" >"$work/base/$api"
image "$work/base" "$work/base.binpb"
"$buf" breaking "$work/head.binpb" --against "$work/base.binpb" --path "$api" --config buf.yaml
echo "check-proto: no breaking change against $(git rev-parse --short "$base")"
