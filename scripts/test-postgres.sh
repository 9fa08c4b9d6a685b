#!/usr/bin/env bash
# A throwaway PostgreSQL server for the tests (Debian's postgresql package), on a Unix socket in
# DIR only (no TCP), trust authentication for the role "soilvol"; ctest starts and stops it as
# the fixture of the records tests (tests/server/records/CMakeLists.txt).
#   scripts/test-postgres.sh start DIR   initdb (first time) and start; prints the URL pattern
#   scripts/test-postgres.sh stop DIR    stop it (fast shutdown)
# As root the server runs as the postgres user (initdb refuses root), in a directory under /tmp
# when that user cannot reach DIR.
set -euo pipefail
action="${1:?start or stop}"
dir=$(realpath -m "${2:?directory}")
bin=$(find /usr/lib/postgresql -maxdepth 2 -name bin -type d 2>/dev/null | sort -V | tail -n 1)
if [ -z "$bin" ]; then
    echo "test-postgres: no PostgreSQL server (apt-get install postgresql)" >&2
    exit 1
fi
as=()
if [ "$(id -u)" -eq 0 ]; then
    as=(runuser -u postgres --)
    # The postgres user must reach DIR: a clone under /root or a mode-700 directory is closed
    # to it. Then the server lives in a directory of its own under /tmp, named after DIR (the
    # same for start and stop), and the URL names that one.
    if ! runuser -u postgres -- test -x "$(dirname "$dir")" 2>/dev/null; then
        dir="/tmp/soilvol-pg-$(printf '%s' "$dir" | sha256sum | cut -c1-16)"
    fi
fi
if [ ${#dir} -gt 90 ]; then
    echo "test-postgres: '$dir' is too long for a Unix socket path" >&2
    exit 1
fi

case "$action" in
    start)
        mkdir -p "$dir"
        if [ ${#as[@]} -gt 0 ]; then chown postgres "$dir" && chmod 700 "$dir"; fi
        if [ -f "$dir/data/postmaster.pid" ]; then
            "${as[@]}" "$bin/pg_ctl" -D "$dir/data" -m immediate stop >/dev/null 2>&1 || true
        fi
        if [ ! -f "$dir/data/PG_VERSION" ]; then
            "${as[@]}" "$bin/initdb" -D "$dir/data" -A trust -U soilvol -E UTF8 --no-sync >"$dir/initdb.log"
        fi
        "${as[@]}" "$bin/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w -t 60 \
            -o "-k $dir -c listen_addresses='' -c max_connections=200" start >/dev/null
        echo "postgresql:///{db}?host=$dir&user=soilvol"
        ;;
    stop)
        if [ -f "$dir/data/postmaster.pid" ]; then
            "${as[@]}" "$bin/pg_ctl" -D "$dir/data" -m fast -w stop >/dev/null
        fi
        ;;
    *)
        echo "test-postgres: start or stop" >&2
        exit 2
        ;;
esac
