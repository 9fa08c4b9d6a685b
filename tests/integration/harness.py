"""Starts real soilvol-server processes on ephemeral ports with temporary data directories,
and talks to them over REST (urllib). Paths come from the environment that CTest sets:
SOILVOL_SERVER_BIN, SOILVOL_CLI_BIN, SOILVOL_PROTO_PYTHON.

External mode: with SOILVOL_EXTERNAL_GRPC (host:port) and SOILVOL_EXTERNAL_HTTP (http://host:port)
set, `shared_server()` is that running server (the compose integration container, run_suite.py)
and the tests that need a process of their own (flags, signals, logs, data directories) skip."""
import base64
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import urllib.error
import urllib.request

SERVER_BIN = os.environ.get("SOILVOL_SERVER_BIN", "build/server/soilvol-server")
CLI_BIN = os.environ.get("SOILVOL_CLI_BIN", "build/client/soilvol")
EXTERNAL_GRPC = os.environ.get("SOILVOL_EXTERNAL_GRPC")
EXTERNAL_HTTP = os.environ.get("SOILVOL_EXTERNAL_HTTP")
EXTERNAL = bool(EXTERNAL_GRPC or EXTERNAL_HTTP)
# A secured external server: the bearer token its tests use (read, estimate and admin scopes)
# and the CA that signed its certificate (https:// and TLS gRPC).
EXTERNAL_TOKEN = os.environ.get("SOILVOL_EXTERNAL_TOKEN")
EXTERNAL_CA = os.environ.get("SOILVOL_EXTERNAL_CA")
# Time limits that depend on how fast the engine computes are multiplied by this: the
# sanitizer build (scripts/sanitize.sh) runs the same tests several times slower.
TIME_SCALE = float(os.environ.get("SOILVOL_TEST_TIME_SCALE", "1"))


class RestClient:
    """REST calls to `self.base_url`; over TLS with `self.ssl_context`, with `self.token` as a
    bearer token unless the call's headers say otherwise."""
    ssl_context = None
    token = EXTERNAL_TOKEN

    def rest(self, method, path, body=None, raw=None, headers=None, timeout_s=120):
        """(HTTP status, parsed JSON or text) for one request. `raw` sends bytes as they are."""
        status, payload, _ = self.rest_with_headers(method, path, body, raw, headers, timeout_s)
        return status, payload

    def rest_with_headers(self, method, path, body=None, raw=None, headers=None, timeout_s=120):
        """(HTTP status, parsed JSON or text, response headers) for one request."""
        data = raw if raw is not None else (json.dumps(body).encode() if body is not None else None)
        hdrs = {"Content-Type": "application/json"}
        if self.token:
            hdrs["Authorization"] = f"Bearer {self.token}"
        hdrs.update(headers or {})
        hdrs = {k: v for k, v in hdrs.items() if v is not None}
        req = urllib.request.Request(self.base_url + path, method=method, data=data, headers=hdrs)
        try:
            with urllib.request.urlopen(req, timeout=timeout_s, context=self.ssl_context) as r:
                status, text, got = r.status, r.read().decode(), r.headers
        except urllib.error.HTTPError as e:
            status, text, got = e.code, e.read().decode(), e.headers
        if "json" in got.get("Content-Type", ""):
            return status, json.loads(text) if text else None, got
        return status, text, got


class Server(RestClient):
    """One soilvol-server process. Use as a context manager, or call start()/stop()."""

    def __init__(self, data_dir=None, args=(), env=None, tls_ca=None, token=None):
        """`tls_ca`: the server runs TLS (its args give the files) and clients trust this CA;
        `token`: the bearer token REST calls carry by default."""
        self.tls_ca = tls_ca
        self.token = token
        if tls_ca:
            import ssl
            self.ssl_context = ssl.create_default_context(cafile=tls_ca)
        self.own_dir = data_dir is None
        self.data_dir = data_dir or tempfile.mkdtemp(prefix="soilvol-it-")
        self.args = list(args)
        self.env = env
        self.proc = None
        self.grpc_port = None
        self.http_port = None
        self.log = []
        self.own_process = True
        self._listening = threading.Event()

    def start(self, timeout_s=30):
        cmd = [SERVER_BIN, "--grpc-address", "127.0.0.1:0", "--http-address", "127.0.0.1:0",
               "--data-dir", self.data_dir] + self.args
        env = dict(os.environ)
        env.update(self.env or {})
        self.proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                     text=True, env=env)
        self._reader = threading.Thread(target=self._read_log, daemon=True)
        self._reader.start()
        if not self._listening.wait(timeout_s):
            self.stop()
            raise RuntimeError("server did not start:\n" + "\n".join(self.log))
        return self

    def _read_log(self):
        for line in self.proc.stderr:
            self.log.append(line.rstrip("\n"))
            m = re.search(r"listening grpc_port=(\d+) http_port=(\d+)", line)
            if m:
                self.grpc_port, self.http_port = int(m.group(1)), int(m.group(2))
                self._listening.set()

    @property
    def grpc_target(self):
        return f"127.0.0.1:{self.grpc_port}"

    @property
    def base_url(self):
        return f"{'https' if self.tls_ca else 'http'}://127.0.0.1:{self.http_port}"

    def channel(self, grpc, token=None, options=None):
        """A gRPC channel to this server: TLS when it runs TLS, `token` (default: the server's)
        on every call, gRPC channel `options`."""
        return make_channel(grpc, self.grpc_target, self.tls_ca,
                            token if token is not None else self.token, options)

    def stop(self, sig=signal.SIGTERM, timeout_s=30):
        """Stops the process; returns its exit code."""
        if self.proc is None:
            return None
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            code = self.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait()
        self._reader.join(5)
        self.proc.stderr.close()
        return code

    def alive(self):
        return self.proc is not None and self.proc.poll() is None

    def close(self):
        """stop(), then removes the data directory when this object created it."""
        code = self.stop()
        if self.own_dir:
            shutil.rmtree(self.data_dir, ignore_errors=True)
        return code

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()



class ExternalServer(RestClient):
    """A server this process did not start (external mode): same calls as Server, no process,
    no log."""

    def __init__(self, grpc_target=EXTERNAL_GRPC, base_url=EXTERNAL_HTTP):
        if not (grpc_target and base_url):
            raise RuntimeError("external mode needs both SOILVOL_EXTERNAL_GRPC and "
                               "SOILVOL_EXTERNAL_HTTP")
        self.grpc_target = grpc_target
        self.base_url = base_url.rstrip("/")
        self.log = []
        self.own_process = False
        self.tls_ca = EXTERNAL_CA
        if EXTERNAL_CA:
            import ssl
            self.ssl_context = ssl.create_default_context(cafile=EXTERNAL_CA)

    def channel(self, grpc, token=None, options=None):
        return make_channel(grpc, self.grpc_target, self.tls_ca,
                            token if token is not None else self.token, options)

    def start(self, timeout_s=60):
        """Waits until the server reports ready on /readyz."""
        if not wait_until(self.alive, timeout_s=timeout_s, step_s=0.5):
            raise RuntimeError(f"{self.base_url}/readyz did not answer 200 in {timeout_s} s")
        return self

    def alive(self):
        try:
            return self.rest("GET", "/readyz", timeout_s=5)[0] == 200
        except OSError:
            return False

    def stop(self, *_args, **_kwargs):
        return 0

    def close(self):
        return 0


def make_channel(grpc, target, tls_ca=None, token=None, options=None):
    """A channel to `target`: TLS trusting `tls_ca` when given, `token` as a bearer token on
    every call (an interceptor, so that it also works without TLS), gRPC channel `options`."""
    if tls_ca:
        with open(tls_ca, "rb") as f:
            channel = grpc.secure_channel(target, grpc.ssl_channel_credentials(f.read()),
                                          options=options)
    else:
        channel = grpc.insecure_channel(target, options=options)
    if not token:
        return channel
    return grpc.intercept_channel(channel, BearerInterceptor(grpc, token))


class BearerInterceptor:
    """Adds `authorization: Bearer <token>` to every call of a channel."""

    def __new__(cls, grpc, token):
        class Interceptor(grpc.UnaryUnaryClientInterceptor, grpc.StreamStreamClientInterceptor,
                          grpc.UnaryStreamClientInterceptor):
            def _with_token(self, details):
                metadata = list(details.metadata or []) + [("authorization", f"Bearer {token}")]
                return details._replace(metadata=metadata)

            def intercept_unary_unary(self, continuation, details, request):
                return continuation(self._with_token(details), request)

            def intercept_unary_stream(self, continuation, details, request):
                return continuation(self._with_token(details), request)

            def intercept_stream_stream(self, continuation, details, requests):
                return continuation(self._with_token(details), requests)

        return Interceptor()


def shared_server(args=("--workers", "2")):
    """The server a test class shares: the external one in external mode, else a new process
    with `args`, started."""
    if EXTERNAL:
        return ExternalServer().start()
    return Server(args=list(args)).start()


def needs_own_server(item):
    """Skips a test or class in external mode: it starts servers with its own flags, signals
    them or reads their logs."""
    return unittest.skipIf(EXTERNAL, "needs a server process of its own (external mode)")(item)


def postgres_url():
    """The test PostgreSQL server's database "postgres" ($SOILVOL_TEST_POSTGRES_URL, a libpq URI
    pattern with {db}; ctest's fixture starts the server), or "" without one."""
    pattern = os.environ.get("SOILVOL_TEST_POSTGRES_URL", "")
    return pattern.replace("{db}", "postgres") if pattern else ""


def needs_postgres(item):
    """Skips a test or class without a test PostgreSQL server, except under CI=true (where its
    records_args then fails: CI must run both databases)."""
    return unittest.skipIf(not postgres_url() and os.environ.get("CI") != "true",
                           "no PostgreSQL ($SOILVOL_TEST_POSTGRES_URL)")(item)


def postgres_records_args():
    """The server flags of a test class's PostgreSQL records."""
    if not postgres_url():
        raise AssertionError("CI=true but SOILVOL_TEST_POSTGRES_URL is not set")
    return ["--records-url", postgres_url()]


def b64(data):
    return base64.b64encode(data).decode()


def cloud_scan(ply_bytes):
    return {"cloud": {"data": b64(ply_bytes)}}


def corners_json(corners):
    return {"corners": [{"x": x, "y": y, "z": z} for x, y, z in corners]}


CURL = shutil.which("curl")


def write_file(directory, name, data):
    """Writes `data` (bytes) to `directory`/`name`; returns the path."""
    path = os.path.join(directory, name)
    with open(path, "wb") as f:
        f.write(data)
    return path


def curl_json(server, path, *args):
    """(HTTP status, parsed JSON or None) of `curl <args> <server><path>`, with the server's CA
    and token when it has them: what an integrator's shell script sends."""
    cmd = [CURL, "-sS", "-o", "-", "-w", "\n%{http_code}"]
    if getattr(server, "tls_ca", None):
        cmd += ["--cacert", server.tls_ca]
    if getattr(server, "token", None):
        cmd += ["-H", f"Authorization: Bearer {server.token}"]
    out = subprocess.run(cmd + list(args) + ["--url", server.base_url + path], check=True,
                         capture_output=True, timeout=120).stdout.decode()
    body, _, status = out.rpartition("\n")
    return int(status), json.loads(body) if body else None


def post_json(server, directory, path, body):
    """(HTTP status, parsed JSON) of POSTing `body` (a dict) as JSON to `path` with curl, the
    body written to `directory` first (large scans exceed a command line)."""
    data = write_file(directory, "request.json", json.dumps(body).encode())
    return curl_json(server, path, "-H", "Content-Type: application/json", "--data-binary",
                     f"@{data}")


class SharedServerCase(unittest.TestCase):
    """Tests against the shared server over REST (curl) and gRPC: `server`, `stub` (gRPC
    modules `grpc_modules`, as load_grpc gives them) and a scratch directory `dir` named after
    `scratch_prefix`; `setUpServer` (a classmethod) adds what the case registers."""
    grpc_modules = None
    scratch_prefix = "soilvol-"

    @classmethod
    def setUpClass(cls):
        grpc, _, pb_grpc = cls.grpc_modules
        cls.server = shared_server()
        cls.channel = cls.server.channel(grpc)
        cls.stub = pb_grpc.SoilVolumeStub(cls.channel)
        cls.dir = tempfile.mkdtemp(prefix=cls.scratch_prefix)
        cls.setUpServer()

    @classmethod
    def setUpServer(cls):
        pass

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        shutil.rmtree(cls.dir, ignore_errors=True)
        cls.server.close()


def wait_until(predicate, timeout_s=10.0, step_s=0.05):
    end = time.time() + timeout_s
    while time.time() < end:
        if predicate():
            return True
        time.sleep(step_s)
    return predicate()


def metric(text, name, **labels):
    """Sum of the samples of `name` in Prometheus text whose labels include `labels`; 0 when
    there are none."""
    total = 0.0
    for line in text.splitlines():
        m = re.match(r"([a-zA-Z_:][a-zA-Z0-9_:]*)(?:\{(.*)\})? (\S+)$", line)
        if not m or m.group(1) != name:
            continue
        have = dict(re.findall(r'(\w+)="((?:[^"\\]|\\.)*)"', m.group(2) or ""))
        if all(have.get(k) == v for k, v in labels.items()):
            total += float(m.group(3))
    return total


def server_metric(server, name, **labels):
    """`metric` of the server's /metrics page now."""
    status, text = server.rest("GET", "/metrics")
    if status != 200:
        raise RuntimeError(f"/metrics answered {status}")
    return metric(text, name, **labels)


SKIPPED = 77  # CTest's SKIP_RETURN_CODE for the integration tests


def load_grpc():
    """(grpc, soilvol_pb2, soilvol_pb2_grpc): python3-grpcio and the stubs generated into
    $SOILVOL_PROTO_PYTHON. Exits with SKIPPED when grpc does not import or the variable is not
    set; stubs that are missing or do not import from the folder it names are an error."""
    proto_dir = os.environ.get("SOILVOL_PROTO_PYTHON")
    if not proto_dir:
        print("skipped: SOILVOL_PROTO_PYTHON is not set (no generated python stubs)",
              file=sys.stderr)
        sys.exit(SKIPPED)
    try:
        import grpc  # before the stub folder is on the path: it holds a grpc/ folder too
    except ImportError as e:
        print(f"skipped: python grpc is not installed ({e})", file=sys.stderr)
        sys.exit(SKIPPED)
    sys.path.insert(0, proto_dir)
    from soilvol.v1 import soilvol_pb2, soilvol_pb2_grpc
    return grpc, soilvol_pb2, soilvol_pb2_grpc


def openssl(*args, cwd):
    subprocess.run(["openssl", *args], cwd=cwd, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.PIPE)


class Pki:
    """A throwaway certificate authority in `folder` (openssl CLI): ca.crt, and per name a key
    and a certificate it signed (server ones for localhost and 127.0.0.1)."""

    def __init__(self, folder, ca_name="ca"):
        self.folder = folder
        self.ca = ca_name
        openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
                "-nodes", "-days", "2", "-subj", f"/CN=soilvol test {ca_name}",
                "-keyout", f"{ca_name}.key", "-out", f"{ca_name}.crt", cwd=folder)

    def path(self, name):
        return os.path.join(self.folder, name)

    def issue(self, name, server=True, serial=None):
        """(cert path, key path) of a new certificate `name` signed by this CA."""
        ext = os.path.join(self.folder, f"{name}.ext")
        with open(ext, "w") as f:
            f.write("subjectAltName=DNS:localhost,IP:127.0.0.1\nextendedKeyUsage=serverAuth\n"
                    if server else "extendedKeyUsage=clientAuth\n")
        openssl("req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
                "-subj", f"/CN={name}", "-keyout", f"{name}.key", "-out", f"{name}.csr",
                cwd=self.folder)
        openssl("x509", "-req", "-in", f"{name}.csr", "-CA", f"{self.ca}.crt", "-CAkey",
                f"{self.ca}.key", "-days", "2", "-extfile", ext,
                *(["-set_serial", str(serial)] if serial else ["-CAcreateserial"]),
                "-out", f"{name}.crt", cwd=self.folder)
        return self.path(f"{name}.crt"), self.path(f"{name}.key")


def token_line(name, scopes, token):
    """A line of a --auth-tokens-file for `token`."""
    import hashlib
    return f"{name} {scopes} sha256:{hashlib.sha256(token.encode()).hexdigest()}\n"
