"""Runs the integration suite (every test_*.py here) against one running soilvol-server, as the
compose integration container does (docker/compose.yaml):

    run_suite.py --grpc server:50051 --http https://server:8080 \\
        --tls-ca ca.crt --token-file admin.token       # a TLS server that asks for tokens
    run_suite.py --grpc host:50051 --http http://host:8080   # an open server
    run_suite.py --start-server      # starts build/server/soilvol-server itself (CTest does this)
    run_suite.py --start-server --secure   # with TLS and a token from scripts/dev-secrets.sh

--tls-ca and --token-file (or SOILVOL_TLS_CA and SOILVOL_TOKEN_FILE, the CLI's variables) reach
the suites as SOILVOL_EXTERNAL_CA / SOILVOL_EXTERNAL_TOKEN (harness.py) and as the CLI's own
variables (test_cli.py). The token needs the scopes read, estimate and admin.

The tests that need a server process of their own skip (harness.needs_own_server). The suite
registers fixed ids, so the server must start with an empty data directory: a server that
already holds containers or calibrations is refused, which also keeps the suite away from a
production store. Exit 0 when every suite passed, 1 when one failed, 2 on a bad setup."""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time

# harness.py reads SOILVOL_EXTERNAL_CA and SOILVOL_EXTERNAL_TOKEN when it is imported, so it is
# imported only once main() has set them from the arguments.
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
DEV_SECRETS = os.path.join(HERE, "..", "..", "scripts", "dev-secrets.sh")
# The CLI suite first: its demo checks that it leaves no demo-* containers behind.
ORDER = ["test_cli.py", "test_rest.py", "test_grpc.py", "test_buf.py", "test_concurrency.py"]


def suites():
    found = sorted(f for f in os.listdir(HERE) if f.startswith("test_") and f.endswith(".py"))
    return [f for f in ORDER if f in found] + [f for f in found if f not in ORDER]


def credentials_env(tls_ca, token_file):
    """The variables that point harness.py's external mode and the soilvol CLI at a TLS server
    (`tls_ca`: the CA of its certificate) with the bearer token in `token_file`."""
    env = {}
    if tls_ca:
        ca = os.path.abspath(tls_ca)
        if not os.path.isfile(ca):
            raise SystemExit(f"run_suite: --tls-ca {tls_ca}: no such file")
        env.update(SOILVOL_EXTERNAL_CA=ca, SOILVOL_TLS_CA=ca)
    if token_file:
        try:
            with open(token_file) as f:
                token = f.read().strip()
        except OSError as e:
            raise SystemExit(f"run_suite: --token-file {token_file}: {e.strerror}") from None
        if not token or any(c.isspace() for c in token):
            raise SystemExit(f"run_suite: --token-file {token_file}: not one token")
        env.update(SOILVOL_EXTERNAL_TOKEN=token, SOILVOL_TOKEN_FILE=os.path.abspath(token_file))
    return env


def stored_ids(server):
    """Ids of the containers and calibrations the server holds, or raises on a bad answer."""
    ids = []
    for path, key, field in (("/v1/containers", "containers", "containerId"),
                             ("/v1/calibrations", "calibrations", "calibrationId")):
        status, body = server.rest("GET", path, timeout_s=30)
        if status != 200:
            raise RuntimeError(f"GET {path} answered {status}: {body}")
        ids += [item[field] for item in (body or {}).get(key, [])]
    return ids


def run(grpc_target, http_url):
    from harness import SKIPPED
    env = dict(os.environ, SOILVOL_EXTERNAL_GRPC=grpc_target, SOILVOL_EXTERNAL_HTTP=http_url)
    results = []
    for name in suites():
        start = time.monotonic()
        code = subprocess.call([sys.executable, os.path.join(HERE, name)], env=env)
        results.append((name, code, time.monotonic() - start))
    print("\nsuite                  result    time")
    for name, code, seconds in results:
        outcome = {0: "passed", SKIPPED: "skipped"}.get(code, f"FAILED ({code})")
        print(f"{name:<22} {outcome:<9} {seconds:5.1f} s")
    failed = [name for name, code, _ in results if code not in (0, SKIPPED)]
    if failed:
        print(f"failed: {' '.join(failed)}", file=sys.stderr)
        return 1
    if all(code == SKIPPED for _, code, _ in results):
        print("every suite skipped itself: nothing was tested", file=sys.stderr)
        return 1
    return 0


def parse_args():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grpc", help="gRPC target host:port of the running server")
    parser.add_argument("--http", help="REST base URL of the running server, http(s)://host:port")
    parser.add_argument("--tls-ca", default=os.environ.get("SOILVOL_TLS_CA"),
                        help="PEM CA of the server's certificate: TLS on both transports "
                             "(env SOILVOL_TLS_CA); --http must then be https://")
    parser.add_argument("--token-file", default=os.environ.get("SOILVOL_TOKEN_FILE"),
                        help="file holding a bearer token with the scopes read, estimate and "
                             "admin (env SOILVOL_TOKEN_FILE)")
    parser.add_argument("--start-server", action="store_true",
                        help="start $SOILVOL_SERVER_BIN on ephemeral ports instead")
    parser.add_argument("--secure", action="store_true",
                        help="with --start-server: TLS and a token file, made by "
                             "scripts/dev-secrets.sh")
    parser.add_argument("--wait-s", type=float, default=120,
                        help="how long to wait for the server to be ready")
    args = parser.parse_args()
    if args.start_server == bool(args.grpc or args.http):
        parser.error("give either --start-server or both --grpc and --http")
    if not args.start_server and not (args.grpc and args.http):
        parser.error("--grpc and --http go together")
    if args.secure and not args.start_server:
        parser.error("--secure goes with --start-server")
    if args.start_server and (args.tls_ca or args.token_file) and not args.secure:
        parser.error("--tls-ca and --token-file are for a running server (or use --secure)")
    if args.http and args.http.startswith("http://") and args.tls_ca:
        parser.error("--tls-ca needs an https:// --http URL")
    return args


def main():
    args = parse_args()
    secrets = None
    server_args = ["--workers", "2"]
    if args.secure:
        secrets = tempfile.mkdtemp(prefix="soilvol-suite-secrets-")
        subprocess.run([DEV_SECRETS, "--force", secrets], check=True, stdout=subprocess.DEVNULL)
        args.tls_ca = os.path.join(secrets, "tls", "ca.crt")
        args.token_file = os.path.join(secrets, "admin.token")
        server_args += ["--tls-cert", os.path.join(secrets, "tls", "tls.crt"),
                        "--tls-key", os.path.join(secrets, "tls", "tls.key"),
                        "--auth-tokens-file", os.path.join(secrets, "auth", "tokens"),
                        "--metrics", "auth"]
    try:
        credentials = credentials_env(args.tls_ca, args.token_file)
        os.environ.update(credentials)
        from harness import Server
        server = None
        if args.start_server:
            server = Server(args=server_args, tls_ca=credentials.get("SOILVOL_EXTERNAL_CA"),
                            token=credentials.get("SOILVOL_EXTERNAL_TOKEN")).start()
            grpc_target, http_url = server.grpc_target, server.base_url
        else:
            grpc_target, http_url = args.grpc, args.http.rstrip("/")
        try:
            result = check_and_run(grpc_target, http_url, args.wait_s)
        finally:
            code = server.close() if server is not None else 0
    finally:
        if secrets:
            shutil.rmtree(secrets, ignore_errors=True)
    if code != 0:
        print(f"the server exited with {code}", file=sys.stderr)
        return 1
    return result


def check_and_run(grpc_target, http_url, wait_s):
    from harness import ExternalServer
    try:
        external = ExternalServer(grpc_target, http_url).start(timeout_s=wait_s)
        held = stored_ids(external)  # also checks the token: the list calls need one
    except RuntimeError as e:
        print(f"run_suite: {e}", file=sys.stderr)
        return 2
    if held:
        print(f"the server at {http_url} already holds {len(held)} entries "
              f"({', '.join(held[:5])}): the suite needs an empty data directory "
              "(with compose: docker compose down -v)", file=sys.stderr)
        return 2
    return run(grpc_target, http_url)


if __name__ == "__main__":
    sys.exit(main())
