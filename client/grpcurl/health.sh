#!/usr/bin/env bash
# grpc.health.v1.Health/Check; exits 0 only when the status is SERVING.
# Usage: health.sh [SERVICE]   (default "": the whole server; or soilvol.v1.SoilVolume)
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=common.sh
source "$(dirname "$0")/common.sh"

service="${1:-}"
[ -z "$service" ] || [[ $service =~ ^[A-Za-z0-9_.]+$ ]] || die "bad service name '$service'"
response="$(printf '{"service":"%s"}' "$service" | rpc grpc.health.v1.Health/Check)"
echo "$response"
grep -q '"SERVING"' <<<"$response"
