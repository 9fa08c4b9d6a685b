#!/usr/bin/env bash
# Starts a soilvol-server on free loopback ports with a fresh data directory and measures it with
# soilvol-load: sequential round trips (gRPC and REST) at 3k, 20k and 100k points, then 8 clients
# on 50k-point scans. Prints the table rows BENCHMARK.md's server section holds.
# Usage: bench/load/run.sh [build-dir]   (nothing else should run on the machine meanwhile)
set -euo pipefail
build="${1:-build}"
server="$build/server/soilvol-server"
load="$build/bench/soilvol-load"
data="$(mktemp -d)"
grpc_port=$((20000 + RANDOM % 20000))
http_port=$((grpc_port + 1))
"$server" --grpc-address "127.0.0.1:$grpc_port" --http-address "127.0.0.1:$http_port" \
    --data-dir "$data" --log-level warn &
pid=$!
trap 'kill "$pid" 2>/dev/null || true; wait "$pid" 2>/dev/null || true; rm -rf "$data"' EXIT
for _ in $(seq 100); do
    if curl -fs "http://127.0.0.1:$http_port/readyz" >/dev/null 2>&1; then break; fi
    sleep 0.1
done
run() { "$load" --grpc "127.0.0.1:$grpc_port" --http "127.0.0.1:$http_port" "$@"; }
echo "| transport | clients | points | requests/s | p50 ms | p99 ms | server total ms | preprocess / align / volume / queue ms (median) | not OK |"
echo "|---|---|---|---|---|---|---|---|---|"
for points in 3000 20000 100000; do
    for transport in grpc rest; do
        run --transport "$transport" --clients 1 --points "$points" --seconds 8 | grep '^|'
    done
done
run --transport grpc --clients 8 --points 50000 --seconds 15 | grep '^|'
run --transport rest --clients 8 --points 50000 --seconds 15 | grep '^|'
