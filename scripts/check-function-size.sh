#!/usr/bin/env bash
# Fails when a function in the given folders (default: server) is longer than the limit
# (default 60 lines, STYLE.md), lambdas inside it included. Function extents come from
# universal-ctags (--fields=+ne: the line a definition starts and the line it ends).
# Usage: scripts/check-function-size.sh [--max N] [folder...]
set -euo pipefail
cd "$(dirname "$0")/.."
max=60
if [ "${1:-}" = "--max" ]; then
    max="$2"
    shift 2
fi
folders=("$@")
[ "${#folders[@]}" -gt 0 ] || folders=(server)
command -v ctags >/dev/null || {
    echo "check-function-size: ctags is missing (scripts/install-deps.sh installs universal-ctags)" >&2
    exit 1
}
long=$(ctags -R --languages=C++ --kinds-C++=f --fields=+ne -o - "${folders[@]}" |
    awk -F'\t' -v max="$max" '{
        start = ""; end = ""
        for (i = 4; i <= NF; i++) {
            if ($i ~ /^line:/) start = substr($i, 6)
            if ($i ~ /^end:/) end = substr($i, 5)
        }
        if (start != "" && end != "" && end - start + 1 > max)
            printf "%s:%s: %s is %d lines\n", $2, start, $1, end - start + 1
    }' | sort)
if [ -n "$long" ]; then
    echo "check-function-size: functions over $max lines:" >&2
    echo "$long" >&2
    exit 1
fi
echo "check-function-size: no function over $max lines in ${folders[*]}"
