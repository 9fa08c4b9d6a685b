#!/usr/bin/env bash
# Installs every Debian package soilvol's build and tests need. Idempotent and non-interactive:
# does nothing when all packages are present. Uses sudo when not run as root.
# Extra groups (not in the images): `fuzz` adds clang, lld and libFuzzer for scripts/fuzz.sh; `test`
# adds what the tests drive the server with: Go and Debian's gRPC Go packages and protoc plugins
# (client/examples/go), Chromium (the browser test) and protoc-gen-swagger (golang-grpc-gateway:
# scripts/gen-openapi.sh and its drift check; the build only embeds the committed document).
set -euo pipefail

packages=(
    build-essential cmake ninja-build pkg-config git ca-certificates
    libeigen3-dev libabsl-dev libpcl-dev libnanoflann-dev liblzf-dev libcli11-dev
    libopencv-dev opencv-doc
    libgrpc++-dev libprotobuf-dev protobuf-compiler protobuf-compiler-grpc grpc-proto
    libboost-dev libssl-dev prometheus-cpp-dev libspdlog-dev libsqlite3-dev libpqxx-dev
    golang-github-gogo-googleapis-dev
    python3 python3-grpcio python3-protobuf python3-numpy python3-yaml curl tzdata
    libgtest-dev libgmock-dev libbenchmark-dev
    clang-format shellcheck yamllint universal-ctags
)
for group in "$@"; do
    case "$group" in
        fuzz) packages+=(clang lld libfuzzer-14-dev libomp-14-dev) ;;
        test)
            # golang-google-grpc-dev accepts either golang/protobuf; apt may pick 1.3, whose
            # well-known types lack the APIv2 methods (AsDuration) the Go example uses.
            packages+=(golang-go golang-google-grpc-dev golang-google-genproto-dev
                golang-google-protobuf-dev golang-github-golang-protobuf-1-5-dev
                protoc-gen-go protoc-gen-go-grpc golang-grpc-gateway chromium postgresql)
            ;;
        *)
            echo "install-deps: unknown group '$group' (fuzz, test)" >&2
            exit 2
            ;;
    esac
done

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
    echo "install-deps: all ${#packages[@]} packages present"
    exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
