#!/usr/bin/env bash
# What recording estimates costs: soilvol-load (gRPC) against soilvol-server with records off,
# in SQLite (the default) and in a PostgreSQL server started here (scripts/test-postgres.sh):
# 20k and 100k points sequentially, then 8 clients on 50k points. Prints the rows of
# BENCHMARK.md's "what recording estimates costs" section, each prefixed with the records.
# Usage: bench/load/records.sh [build-dir]   (nothing else should run on the machine meanwhile)
set -euo pipefail
cd "$(dirname "$0")/../.."
build="${1:-build}"
pg="$(mktemp -d)"
scripts/test-postgres.sh start "$pg" >/dev/null
trap 'scripts/test-postgres.sh stop "$pg" || true; rm -rf "$pg"' EXIT
for records in none sqlite postgres; do
    data="$(mktemp -d)"
    port=$((21000 + RANDOM % 20000))
    case "$records" in
        none) url=none ;;
        sqlite) url="" ;;
        postgres) url="postgresql:///postgres?host=$pg&user=soilvol" ;;
    esac
    SOILVOL_RECORDS_URL="$url" "$build/server/soilvol-server" --grpc-address "127.0.0.1:$port" \
        --http-address "127.0.0.1:$((port + 1))" --data-dir "$data" --log-level warn &
    pid=$!
    for _ in $(seq 100); do
        if curl -fs "http://127.0.0.1:$((port + 1))/readyz" >/dev/null 2>&1; then break; fi
        sleep 0.1
    done
    for args in "--clients 1 --points 20000 --seconds 8" "--clients 1 --points 100000 --seconds 8" \
        "--clients 8 --points 50000 --seconds 12"; do
        # shellcheck disable=SC2086  # $args is several options
        "$build/bench/soilvol-load" --grpc "127.0.0.1:$port" --http "127.0.0.1:$((port + 1))" \
            --transport grpc $args | grep '^| gRPC' | sed "s/^/$records /"
    done
    kill "$pid"
    wait "$pid" 2>/dev/null || true
    rm -rf "$data"
done
