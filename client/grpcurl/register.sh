#!/usr/bin/env bash
# Registers a container from a PLY/PCD scan of it empty and its four opening corners (metres, in
# the scan frame, in order around the opening); replaces a container with the same id.
# Usage: register.sh ID EMPTY.ply "x,y,z;x,y,z;x,y,z;x,y,z" [MAX_RANGE_M]
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=common.sh
source "$(dirname "$0")/common.sh"

(($# >= 3 && $# <= 4)) || die "usage: $0 ID EMPTY.ply \"x,y,z;x,y,z;x,y,z;x,y,z\" [MAX_RANGE_M]"
id="$1"
cloud="$2"
check_id "$id"
check_file "$cloud"
corners="$(corners_json "$3")"
range=""
if [ $# -eq 4 ]; then
    check_number "$4" MAX_RANGE_M
    range=",\"maxRangeM\":$4"
fi

# The cloud goes into the request as base64 (proto3 JSON for bytes), streamed through stdin.
{
    printf '{"containerId":"%s","overwrite":true%s,"opening":{"corners":%s},' \
        "$id" "$range" "$corners"
    printf '"scan":{"cloud":{"data":"'
    base64 -w0 "$cloud"
    printf '"}}}'
} | rpc soilvol.v1.SoilVolume/RegisterContainer
