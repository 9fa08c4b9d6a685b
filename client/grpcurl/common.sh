# shellcheck shell=bash
# Sourced by the example scripts. SERVER is $SOILVOL_SERVER or localhost:50051; `rpc` runs one
# unary RPC through server reflection with grpcurl if it is on PATH, else with `buf curl`
# (npm @bufbuild/buf). SOILVOL_RPC_TOOL=grpcurl|buf picks one explicitly.
SERVER="${SOILVOL_SERVER:-localhost:50051}"

TOOL="${SOILVOL_RPC_TOOL:-}"
if [ -z "$TOOL" ]; then
    if command -v grpcurl >/dev/null 2>&1; then
        TOOL=grpcurl
    elif command -v buf >/dev/null 2>&1; then
        TOOL=buf
    fi
fi
case "$TOOL" in
    grpcurl | buf) command -v "$TOOL" >/dev/null 2>&1 || TOOL="" ;;
    *) TOOL="" ;;
esac
if [ -z "$TOOL" ]; then
    echo "error: neither grpcurl nor buf is on PATH; install one of them:" >&2
    echo "  grpcurl: https://github.com/fullstorydev/grpcurl/releases" >&2
    echo "  buf:     npm install -g @bufbuild/buf" >&2
    exit 127
fi

# rpc SERVICE/METHOD: sends the JSON request read from stdin, prints the JSON response.
rpc() {
    if [ "$TOOL" = grpcurl ]; then
        grpcurl -plaintext -emit-defaults -d @ "$SERVER" "$1"
    else
        buf curl --protocol grpc --http2-prior-knowledge --emit-defaults -d @- "http://$SERVER/$1"
    fi
}

die() {
    echo "error: $*" >&2
    exit 2
}

# check_id ID: the server's id syntax, so that ids need no JSON escaping.
check_id() {
    [[ $1 =~ ^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$ ]] || die "bad id '$1' (want [A-Za-z0-9][A-Za-z0-9._-]{0,63})"
}

# check_number VALUE NAME: a JSON number.
check_number() {
    [[ $1 =~ ^-?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)?$ ]] || die "$2: '$1' is not a number"
}

# check_file PATH: a readable regular file.
check_file() {
    [[ -f $1 && -r $1 ]] || die "cannot read '$1'"
}

# corners_json "x,y,z;x,y,z;x,y,z;x,y,z": the four opening corners as a JSON array of Point3.
corners_json() {
    local json="" point x y z extra
    local -a points
    IFS=';' read -ra points <<<"$1"
    [ "${#points[@]}" -eq 4 ] || die "corners: want 4 points \"x,y,z;x,y,z;x,y,z;x,y,z\", got '$1'"
    for point in "${points[@]}"; do
        IFS=',' read -r x y z extra <<<"${point// /}"
        [ -z "$extra" ] || die "corners: '$point' has more than 3 numbers"
        check_number "$x" corners
        check_number "$y" corners
        check_number "$z" corners
        json+="${json:+,}{\"x\":$x,\"y\":$y,\"z\":$z}"
    done
    printf '[%s]' "$json"
}
