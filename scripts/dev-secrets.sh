#!/usr/bin/env bash
# Creates throwaway TLS and token files for a local, secured soilvol-server (docker/compose.yaml
# mounts them; tests/ship and `run_suite.py --secure` use them too), with the openssl CLI:
#   DIR/tls/ca.crt              a new CA (its key is deleted once it has signed)
#   DIR/tls/tls.crt, tls.key    the server's certificate, for DNS server and localhost, IP 127.0.0.1
#   DIR/admin.token             a random bearer token with the scopes read,estimate,admin
#   DIR/auth/tokens             the --auth-tokens-file holding only that token's SHA-256
# Usage: scripts/dev-secrets.sh [--force] [DIR]   (DIR defaults to docker/secrets, gitignored).
# Existing secrets are kept unless --force, which renames new files over them inside the same
# folders, so a running server (bind-mounted folders) picks them up. For development only:
# production certificates come from your CA or cert-manager (deploy/README.md).
set -euo pipefail

force=0
if [ "${1:-}" = "--force" ]; then
    force=1
    shift
fi
dir="${1:-$(cd "$(dirname "$0")/.." && pwd)/docker/secrets}"
days=90

if [ -e "$dir/auth/tokens" ] && [ "$force" = 0 ]; then
    echo "dev-secrets: $dir already holds secrets (--force replaces them)"
    exit 0
fi
command -v openssl >/dev/null || { echo "dev-secrets: openssl is not installed" >&2; exit 1; }

umask 077
mkdir -p "$dir/tls" "$dir/auth"
# Staged beside the results (same filesystem), so that each file arrives in one rename.
new="$(mktemp -d "$dir/.new.XXXXXX")"
trap 'rm -rf "$new"' EXIT

# The CA, then a server certificate it signs; EC P-256 keys.
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days "$days" \
    -subj "/CN=soilvol development CA" -addext "basicConstraints=critical,CA:TRUE" \
    -addext "keyUsage=critical,keyCertSign,cRLSign" \
    -keyout "$new/ca.key" -out "$new/ca.crt" 2>/dev/null
openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -subj "/CN=server" \
    -keyout "$new/tls.key" -out "$new/server.csr" 2>/dev/null
cat >"$new/server.ext" <<'EXT'
basicConstraints=critical,CA:FALSE
keyUsage=critical,digitalSignature
extendedKeyUsage=serverAuth
subjectAltName=DNS:server,DNS:localhost,IP:127.0.0.1
EXT
openssl x509 -req -in "$new/server.csr" -CA "$new/ca.crt" -CAkey "$new/ca.key" \
    -CAcreateserial -CAserial "$new/ca.srl" -days "$days" -extfile "$new/server.ext" \
    -out "$new/tls.crt" 2>/dev/null

# A random token; the server's file holds only its hash.
token="$(openssl rand -hex 32)"
printf '%s\n' "$token" >"$new/admin.token"
hash="$(printf %s "$token" | sha256sum | cut -d' ' -f1)"
printf '# name scopes sha256:<hex of the token>\nadmin read,estimate,admin sha256:%s\n' "$hash" \
    >"$new/tokens"

# DIR stays private to you (0700); inside it the files are readable by anyone, because the
# containers run as uid 10001 and read them through bind mounts of DIR's subfolders.
chmod 0700 "$dir"
chmod 0755 "$dir/tls" "$dir/auth"
chmod 0644 "$new/ca.crt" "$new/tls.crt" "$new/tls.key" "$new/tokens" "$new/admin.token"
mv -f "$new/ca.crt" "$new/tls.key" "$new/tls.crt" "$dir/tls/"
mv -f "$new/tokens" "$dir/auth/tokens"
mv -f "$new/admin.token" "$dir/admin.token"
echo "dev-secrets: wrote $dir (CA and server certificate for server, localhost, 127.0.0.1," \
    "valid $days days; admin token in $dir/admin.token)"
