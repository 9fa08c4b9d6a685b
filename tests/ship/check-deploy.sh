#!/usr/bin/env bash
# Offline checks of deploy/: yamllint, the Kubernetes schemas (validate_k8s.js, npm
# kubernetes-models) on our own kustomize rendering and, where kubectl is installed, on
# `kubectl kustomize deploy/` and against our rendering, so that the two cannot drift.
# npm packages: $SOILVOL_TOOLS_DIR/node_modules (default ~/.cache/soilvol-tools/node_modules),
# installed by scripts/install-test-tools.sh.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
deploy="$root/deploy"
tools_dir="${SOILVOL_TOOLS_DIR:-$HOME/.cache/soilvol-tools}"
node_modules="$tools_dir/node_modules"

fail() {
    echo "check-deploy: $*" >&2
    exit 1
}

command -v yamllint >/dev/null || fail "yamllint is not installed (apt-get install yamllint)"
command -v node >/dev/null || fail "node is not installed (apt-get install nodejs)"
for package in yaml kubernetes-models; do
    [ -f "$node_modules/$package/package.json" ] ||
        fail "npm package $package is missing from $node_modules (run scripts/install-test-tools.sh)"
done
export NODE_PATH="$node_modules"

echo "check-deploy: yamllint"
yamllint -c "$here/yamllint.yaml" --strict "$deploy"

echo "check-deploy: schemas of our rendering"
node "$here/validate_k8s.js" --kustomize "$deploy"

if command -v kubectl >/dev/null; then
    rendered="$(mktemp)"
    trap 'rm -f "$rendered"' EXIT
    kubectl kustomize "$deploy" >"$rendered"
    echo "check-deploy: schemas of kubectl kustomize"
    node "$here/validate_k8s.js" "$rendered"
    echo "check-deploy: our rendering against kubectl kustomize"
    node "$here/validate_k8s.js" --kustomize "$deploy" --compare "$rendered"
else
    echo "check-deploy: kubectl not installed: kubectl kustomize not compared"
fi
echo "check-deploy: ok"
