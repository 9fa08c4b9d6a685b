#!/usr/bin/env bash
# Static checks of what cannot run here (no Docker engine, no cluster) and of the shell scripts:
# ShellCheck, yamllint, the Dockerfile linter, the compose schema and linter, and the Kubernetes
# manifests (tests/ship/check-deploy.sh: kustomize + OpenAPI schemas), the API (buf lint and
# buf breaking, scripts/check-proto.sh). Consistency with the
# server (ports, flags, packages, users) is tested by CTest's ship.* tests. Needs
# scripts/install-deps.sh and scripts/install-test-tools.sh first; a missing tool is an error.
set -euo pipefail
cd "$(dirname "$0")/.."
tools_dir="${SOILVOL_TOOLS_DIR:-$HOME/.cache/soilvol-tools}"
bin="$tools_dir/node_modules/.bin"

require() {
    if [ ! -x "$1" ] && ! command -v "$1" >/dev/null 2>&1; then
        echo "check-static: $1 is missing (scripts/install-deps.sh, scripts/install-test-tools.sh)" >&2
        exit 1
    fi
}

step() {
    echo "--- $1"
    shift
    "$@"
}

require shellcheck
require yamllint
require "$bin/dockerfile-utils"
require "$bin/dclint"

mapfile -t shell_scripts < <(git ls-files '*.sh' .ci/run)
step "shellcheck (${#shell_scripts[@]} scripts)" shellcheck "${shell_scripts[@]}"
step "yamllint" yamllint --strict -c tests/ship/yamllint.yaml docker/compose.yaml
step "Dockerfile (dockerfile-utils lint)" "$bin/dockerfile-utils" lint docker/Dockerfile
# Compose's schema and its rules, but one: `image` beside `build` names the image it builds.
step "compose (dclint)" "$bin/dclint" --disable-rule no-build-and-image --max-warnings 0 \
    docker/compose.yaml
step "Kubernetes manifests" env SOILVOL_TOOLS_DIR="$tools_dir" tests/ship/check-deploy.sh
step "function size (server/)" scripts/check-function-size.sh server
step "API (buf lint, buf breaking)" env SOILVOL_TOOLS_DIR="$tools_dir" scripts/check-proto.sh
echo "check-static: all passed"
