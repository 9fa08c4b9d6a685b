"""Runs the integration suite (every test_*.py here) against one running soilvol-server, as the
compose integration container does (docker/compose.yaml):

    run_suite.py --grpc server:50051 --http http://server:8080
    run_suite.py --start-server      # starts build/server/soilvol-server itself (CTest does this)

The tests that need a server process of their own skip (harness.needs_own_server). The suite
registers fixed ids, so the server must start with an empty data directory: a server that
already holds containers or calibrations is refused, which also keeps the suite away from a
production store. Exit 0 when every suite passed, 1 when one failed, 2 on a bad setup."""
import argparse
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from harness import SKIPPED, ExternalServer, Server  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
# The CLI suite first: its demo checks that it leaves no demo-* containers behind.
ORDER = ["test_cli.py", "test_rest.py", "test_grpc.py", "test_buf.py", "test_concurrency.py"]


def suites():
    found = sorted(f for f in os.listdir(HERE) if f.startswith("test_") and f.endswith(".py"))
    return [f for f in ORDER if f in found] + [f for f in found if f not in ORDER]


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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grpc", help="gRPC target host:port of the running server")
    parser.add_argument("--http", help="REST base URL of the running server, http://host:port")
    parser.add_argument("--start-server", action="store_true",
                        help="start $SOILVOL_SERVER_BIN on ephemeral ports instead")
    parser.add_argument("--wait-s", type=float, default=120,
                        help="how long to wait for the server to be ready")
    args = parser.parse_args()
    if args.start_server == bool(args.grpc or args.http):
        parser.error("give either --start-server or both --grpc and --http")
    if not args.start_server and not (args.grpc and args.http):
        parser.error("--grpc and --http go together")

    server = None
    if args.start_server:
        server = Server(args=["--workers", "2"]).start()
        grpc_target, http_url = server.grpc_target, server.base_url
    else:
        grpc_target, http_url = args.grpc, args.http.rstrip("/")
    try:
        result = check_and_run(grpc_target, http_url, args.wait_s)
    finally:
        code = server.close() if server is not None else 0
    if code != 0:
        print(f"the server exited with {code}", file=sys.stderr)
        return 1
    return result


def check_and_run(grpc_target, http_url, wait_s):
    external = ExternalServer(grpc_target, http_url).start(timeout_s=wait_s)
    held = stored_ids(external)
    if held:
        print(f"the server at {http_url} already holds {len(held)} entries "
              f"({', '.join(held[:5])}): the suite needs an empty data directory "
              "(with compose: docker compose down -v)", file=sys.stderr)
        return 2
    return run(grpc_target, http_url)


if __name__ == "__main__":
    sys.exit(main())
