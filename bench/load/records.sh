#!/usr/bin/env bash
# What recording estimates costs: soilvol-load (gRPC) against three soilvol-server processes
# running side by side, with records off, in SQLite (the default) and in a PostgreSQL server
# started here (scripts/test-postgres.sh): 20k and 100k points sequentially, then 8 clients on
# 50k points. A shared machine drifts by more than the effect measured, so each shape runs in
# ROUNDS rounds (default 5) that take the three servers in turn (the order rotating), and the
# table gives each server's median over the rounds and its change against records off in the
# same rounds, and the CPU time the server (with PostgreSQL: and its database server) spent
# per estimate, which drifts less than throughput does. Prints the rows of BENCHMARK.md's
# "what recording estimates costs" section.
# Usage: bench/load/records.sh [build-dir] [rounds]   (nothing else should run meanwhile)
set -euo pipefail
cd "$(dirname "$0")/../.."
build="${1:-build}"
rounds="${2:-5}"
work="$(mktemp -d)"
pg="$(mktemp -d)"  # its own: scripts/test-postgres.sh hands it to the postgres user
pids=()
cleanup() {
    for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
    wait 2>/dev/null || true
    scripts/test-postgres.sh stop "$pg" >/dev/null 2>&1 || true
    rm -rf "$work" "$pg"
}
trap cleanup EXIT
scripts/test-postgres.sh start "$pg" >/dev/null
kinds=(none sqlite postgres)
declare -A grpc_port http_port server_pid
base=$((21000 + RANDOM % 20000))
for i in "${!kinds[@]}"; do
    kind="${kinds[$i]}"
    case "$kind" in
        none) url=none ;;
        sqlite) url="" ;;
        postgres) url="postgresql:///postgres?host=$pg&user=soilvol" ;;
    esac
    grpc_port[$kind]=$((base + 2 * i))
    http_port[$kind]=$((base + 2 * i + 1))
    mkdir -p "$work/data-$kind"
    SOILVOL_RECORDS_URL="$url" "$build/server/soilvol-server" \
        --grpc-address "127.0.0.1:${grpc_port[$kind]}" \
        --http-address "127.0.0.1:${http_port[$kind]}" --data-dir "$work/data-$kind" \
        --log-level warn &
    pids+=($!)
    server_pid[$kind]=$!
done
for kind in "${kinds[@]}"; do
    for _ in $(seq 100); do
        if curl -fs "http://127.0.0.1:${http_port[$kind]}/readyz" >/dev/null 2>&1; then break; fi
        sleep 0.1
    done
done
# CPU time [clock ticks] of the server of $1, and of the PostgreSQL server for "postgres".
cpu_ticks() {
    local pids=("${server_pid[$1]}") total=0 pid
    if [ "$1" = postgres ]; then
        local postmaster
        postmaster="$(head -n1 "$pg/data/postmaster.pid")"
        mapfile -t -O 1 pids < <(echo "$postmaster"; pgrep -P "$postmaster")
    fi
    for pid in "${pids[@]}"; do
        # utime + stime: fields 14 and 15 (the command name has no spaces here)
        total=$((total + $(awk '{print $14 + $15}' "/proc/$pid/stat" 2>/dev/null || echo 0)))
    done
    echo "$total"
}
ticks_per_s="$(getconf CLK_TCK)"
warmup=2
for shape in "1 20000 6" "1 100000 6" "8 50000 8"; do
    read -r clients points seconds <<<"$shape"
    for round in $(seq "$rounds"); do
        for step in 0 1 2; do
            kind="${kinds[$(((round + step) % 3))]}"
            "$build/bench/soilvol-load" --grpc "127.0.0.1:${grpc_port[$kind]}" \
                --http "127.0.0.1:${http_port[$kind]}" --transport grpc --clients "$clients" \
                --points "$points" --seconds "$seconds" --warmup "$warmup" >"$work/out" &
            load=$!
            # The CPU the server (and its database) spend in the measured window, per call.
            sleep "$warmup"
            before="$(cpu_ticks "$kind")"
            sleep "$seconds"
            after="$(cpu_ticks "$kind")"
            wait "$load"
            row="$(grep '^| gRPC' "$work/out")"
            echo "$kind $row $(((after - before) * 1000 / ticks_per_s))" >>"$work/rows"
        done
    done
done
# "kind | gRPC | clients | points | req/s | p50 | p99 | total | stages | errors | cpu_ms"
python3 - "$work/rows" <<'PY'
import statistics
import sys

rows = {}
for line in open(sys.argv[1]):
    cells = [c.strip() for c in line.split("|")]
    kind, _, clients, points, rate, p50, p99, total = cells[:8]
    # CPU per estimate: the CPU of the window over the calls in it (rate x seconds)
    seconds = {"1": 6.0, "8": 8.0}[clients]
    cpu = float(cells[-1]) / (float(rate) * seconds)
    rows.setdefault((clients, points), {}).setdefault(kind, []).append(
        (float(rate), float(p50), float(p99), float(total), cpu))
names = {"none": "none", "sqlite": "SQLite", "postgres": "PostgreSQL"}
print("| records | clients | points | rounds | requests/s (median) | change | p50 ms | p99 ms"
      " | server total ms | CPU ms per estimate | change |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for (clients, points), kinds in rows.items():
    base = statistics.median(r[0] for r in kinds["none"])
    base_cpu = statistics.median(r[4] for r in kinds["none"])
    for kind in ("none", "sqlite", "postgres"):
        runs = kinds[kind]
        med = [statistics.median(r[i] for r in runs) for i in range(5)]
        change = "" if kind == "none" else f"{100 * (med[0] - base) / base:+.1f} %"
        cpu_change = "" if kind == "none" else f"{100 * (med[4] - base_cpu) / base_cpu:+.1f} %"
        print(f"| {names[kind]} | {clients} | {points} | {len(runs)} | {med[0]:.1f} | {change} "
              f"| {med[1]:.1f} | {med[2]:.1f} | {med[3]:.1f} | {med[4]:.1f} | {cpu_change} |")
PY
