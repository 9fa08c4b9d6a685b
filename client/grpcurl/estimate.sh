#!/usr/bin/env bash
# Volume of the soil in a PLY/PCD scan of a registered container.
# Usage: estimate.sh ID SCAN.ply [heightmap|paper] [CELL_M]
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=common.sh
source "$(dirname "$0")/common.sh"

(($# >= 2 && $# <= 4)) || die "usage: $0 ID SCAN.ply [heightmap|paper] [CELL_M]"
id="$1"
cloud="$2"
check_id "$id"
check_file "$cloud"
case "${3:-heightmap}" in
    heightmap) method=ESTIMATION_METHOD_HEIGHTMAP ;;
    paper) method=ESTIMATION_METHOD_PAPER ;;
    *) die "method: '$3' is not heightmap or paper" ;;
esac
cell=""
if [ $# -eq 4 ]; then
    check_number "$4" CELL_M
    cell=",\"gridCellM\":$4"
fi

{
    printf '{"containerId":"%s","method":"%s"%s,"scan":{"cloud":{"data":"' "$id" "$method" "$cell"
    base64 -w0 "$cloud"
    printf '"}}}'
} | rpc soilvol.v1.SoilVolume/EstimateVolume
