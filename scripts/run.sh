#!/usr/bin/env bash
# The main job: installs what is missing, builds, and starts soilvol-server on the embedded
# default: models and calibrations in ./data, gRPC on :50051, REST + /healthz + /metrics on
# :8080. On a data directory without it, it first registers a simulated demo bucket
# (`soilvol demo --keep`: container demo-paper) so that there is something to query.
# Ctrl-C (or SIGTERM) stops the server gracefully. SOILVOL_* variables configure it (README).
#   scripts/run.sh demo    the engine demos without a server (point cloud, then stereo)
#   scripts/run.sh bench   regenerates BENCHMARK.md
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
build="${SOILVOL_BUILD_DIR:-build}"
case "${1:-serve}" in
    serve) ;;
    demo)
        "$build/bench/soilvol-bench" demo
        echo
        exec "$build/bench/soilvol-bench" stereo-demo
        ;;
    bench) exec "$build/bench/soilvol-bench" all --out BENCHMARK.md ;;
    *)
        echo "usage: scripts/run.sh [serve|demo|bench]" >&2
        exit 2
        ;;
esac

export SOILVOL_DATA_DIR="${SOILVOL_DATA_DIR:-./data}"
grpc_port="${SOILVOL_GRPC_ADDRESS:-0.0.0.0:50051}"
grpc_port="${grpc_port##*:}"
"$build/server/soilvol-server" &
server=$!
trap 'kill -TERM "$server" 2>/dev/null || true' INT TERM
for _ in $(seq 100); do
    "$build/client/soilvol" --server "127.0.0.1:$grpc_port" --timeout-s 1 health >/dev/null 2>&1 && break
    kill -0 "$server" 2>/dev/null || break
    sleep 0.1
done
if kill -0 "$server" 2>/dev/null && [ ! -e "$SOILVOL_DATA_DIR/containers/demo-paper.entry" ]; then
    "$build/client/soilvol" --server "127.0.0.1:$grpc_port" demo --keep ||
        echo "run.sh: the demo registration failed; the server keeps running" >&2
fi
status=0
wait "$server" || status=$?
if kill -0 "$server" 2>/dev/null; then # a signal interrupted wait; the trap passed it on
    status=0
    wait "$server" || status=$?
fi
exit "$status"
