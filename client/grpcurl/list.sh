#!/usr/bin/env bash
# Lists the server's services and soilvol's methods through reflection.
# Usage: list.sh [SYMBOL]   (grpcurl only: describe SYMBOL, e.g. soilvol.v1.EstimateVolumeRequest)
set -euo pipefail
# shellcheck source-path=SCRIPTDIR source=common.sh
source "$(dirname "$0")/common.sh"

if [ "$TOOL" = grpcurl ]; then
    if [ $# -gt 0 ]; then
        exec grpcurl -plaintext "$SERVER" describe "$1"
    fi
    grpcurl -plaintext "$SERVER" list
    echo
    grpcurl -plaintext "$SERVER" describe soilvol.v1.SoilVolume
else
    [ $# -eq 0 ] || echo "note: buf curl cannot describe symbols; listing methods" >&2
    buf curl --protocol grpc --http2-prior-knowledge --list-services "http://$SERVER"
    echo
    buf curl --protocol grpc --http2-prior-knowledge --list-methods "http://$SERVER"
fi
