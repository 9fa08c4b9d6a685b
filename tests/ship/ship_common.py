"""What test_docker.py and test_deploy.py both need: the server's flags, the Dockerfile's
stages, throwaway secrets (scripts/dev-secrets.sh) in place of the mounted ones, a server process
started from an environment like a container's, and clients that speak TLS with a token."""
import json
import os
import queue
import re
import shlex
import shutil
import signal
import ssl
import subprocess
import tempfile
import threading
import urllib.error
import urllib.request

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DEV_SECRETS = os.path.join(ROOT, "scripts", "dev-secrets.sh")


def port_of(address):
    return int(address.rsplit(":", 1)[1])


def is_loopback(address):
    """True for a host:port only this machine reaches (the server's own rule)."""
    host = address.rsplit(":", 1)[0].strip("[]")
    return host in ("localhost", "::1") or host.startswith("127.")


def help_env(binary):
    """{variable: default text or None} of the SOILVOL_* variables a binary's --help lists."""
    text = subprocess.run([binary, "--help"], capture_output=True, text=True, timeout=30,
                          check=True).stdout
    found = {}
    for m in re.finditer(r"^\s*--[\w-]+ (.*?)\(Env:(SOILVOL_\w+)\)", text, re.MULTILINE):
        default = re.match(r"\S+?=(\S+)", m.group(1))  # "TEXT=0.0.0.0:50051 "; "TEXT ... "
        found[m.group(2)] = default.group(1) if default else None
    return found


def parse_dockerfile(path):
    """[(stage name, [(instruction, arguments)])] with continuation lines joined; what comes
    before the first FROM (global ARGs) is the stage "(global)"."""
    with open(path) as f:
        text = f.read()
    logical, current = [], ""
    for line in text.splitlines():
        if line.lstrip().startswith("#") or (not current and not line.strip()):
            continue  # comments, also inside a continued instruction
        if line.endswith("\\"):
            current += line[:-1] + " "
            continue
        logical.append(current + line)
        current = ""
    stages = []
    for line in logical:
        instruction, _, args = line.strip().partition(" ")
        instruction = instruction.upper()
        if instruction == "FROM":
            m = re.match(r"(\S+)(?:\s+AS\s+(\S+))?", args.strip(), re.IGNORECASE)
            stages.append((m.group(2) or m.group(1), [("FROM", m.group(1))]))
        elif stages:
            stages[-1][1].append((instruction, args.strip()))
        else:
            stages.append(("(global)", [(instruction, args.strip())]))
    return stages


def env_of(instructions):
    """The ENV key=value pairs of a stage's instructions, in order."""
    env = {}
    for instruction, args in instructions:
        if instruction == "ENV":
            for word in shlex.split(args):
                key, _, value = word.partition("=")
                env[key] = value
    return env


class DevSecrets:
    """What scripts/dev-secrets.sh writes, in a temporary folder: tls/{ca.crt,tls.crt,tls.key}
    (a certificate for localhost and 127.0.0.1), auth/tokens and admin.token (all scopes)."""

    def __init__(self):
        self.dir = tempfile.mkdtemp(prefix="soilvol-ship-secrets-")
        try:
            subprocess.run([DEV_SECRETS, "--force", self.dir], check=True, capture_output=True,
                           timeout=60)
        except subprocess.SubprocessError:
            self.close()
            raise
        self.tls = os.path.join(self.dir, "tls")
        self.auth = os.path.join(self.dir, "auth")
        self.ca = os.path.join(self.tls, "ca.crt")
        self.token_file = os.path.join(self.dir, "admin.token")
        with open(self.token_file) as f:
            self.token = f.read().strip()

    def mounted(self, env, mounts):
        """`env` with each path under a mount point of `mounts` ({mount path: our folder})
        moved to our folder, as the container sees the mounted Secret there."""
        moved = {}
        for key, value in env.items():
            for mount, folder in mounts.items():
                if value.startswith(mount.rstrip("/") + "/"):
                    value = os.path.join(folder, value[len(mount.rstrip("/")) + 1:])
            moved[key] = value
        return moved

    def close(self):
        shutil.rmtree(self.dir, ignore_errors=True)


def parse_log_line(line):
    """The fields of one log line, text (key=value, key="quoted") or JSON; numbers as int."""
    if line.startswith("{"):
        return json.loads(line)
    fields = {}
    for key, value in re.findall(r'(\w+)=("(?:[^"\\]|\\.)*"|\S+)', line):
        value = json.loads(value) if value.startswith('"') else value
        fields[key] = int(value) if re.fullmatch(r"\d+", str(value)) else value
    return fields


def rest(url, ca=None, token=None, timeout_s=10):
    """HTTP status of GET `url` (no proxy), over TLS trusting `ca`, with `token` as a bearer
    token when given."""
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    handlers = [urllib.request.ProxyHandler({})]
    if ca:
        handlers.append(urllib.request.HTTPSHandler(context=ssl.create_default_context(cafile=ca)))
    opener = urllib.request.build_opener(*handlers)
    try:
        with opener.open(urllib.request.Request(url, headers=headers), timeout=timeout_s) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


class ServerProcess:
    """soilvol-server with `env` over our environment minus its SOILVOL_* variables, on
    ephemeral loopback ports (a probe listener too when `env` asks for one) and a temporary
    data directory, as a container would run it."""

    def __init__(self, binary, env):
        self.data_dir = tempfile.mkdtemp(prefix="soilvol-ship-")
        full = {k: v for k, v in os.environ.items() if not k.startswith("SOILVOL_")}
        full.update(env)
        full.update(SOILVOL_GRPC_ADDRESS="127.0.0.1:0", SOILVOL_HTTP_ADDRESS="127.0.0.1:0",
                    SOILVOL_DATA_DIR=self.data_dir)
        if env.get("SOILVOL_PROBE_ADDRESS"):
            full["SOILVOL_PROBE_ADDRESS"] = "127.0.0.1:0"
        self.proc = subprocess.Popen([binary], env=full, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, text=True)
        self.log = []
        self._lines = queue.Queue()
        # Reads stderr on a thread, so that a full pipe never blocks the server; None = EOF.
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.proc.stderr:
            self._lines.put(line)
        self._lines.put(None)

    def wait_listening(self, timeout_s=30):
        """The fields of the `listening` log line (text or JSON format); AssertionError with
        the log when it does not come."""
        while True:
            try:
                line = self._lines.get(timeout=timeout_s)
            except queue.Empty:
                raise AssertionError(f"no 'listening' line within {timeout_s} s; stderr: "
                                     f"{''.join(self.log)}") from None
            if line is None:
                raise AssertionError(f"soilvol-server exited before listening; stderr: "
                                     f"{''.join(self.log)}")
            self.log.append(line)
            if line.startswith("{") or " listening " in line:
                fields = parse_log_line(line)
                if line.startswith("{") and fields.get("msg") != "listening":
                    continue
                return fields

    def wait_exit(self, timeout_s=30):
        """The exit code of a server expected to stop by itself, and its stderr; AssertionError
        (after stopping it) when it is still running after `timeout_s`."""
        try:
            code = self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.stop()
            raise AssertionError(f"soilvol-server still runs after {timeout_s} s; stderr: "
                                 f"{''.join(self.log)}") from None
        self._reader.join(timeout=10)
        while not self._lines.empty():
            line = self._lines.get()
            if line is not None:
                self.log.append(line)
        self.proc.stderr.close()
        shutil.rmtree(self.data_dir, ignore_errors=True)
        return code, "".join(self.log)

    def stop(self, timeout_s=30):
        """SIGTERM; the exit code. Removes the data directory."""
        self.proc.send_signal(signal.SIGTERM)
        try:
            return self.proc.wait(timeout=timeout_s)
        finally:
            self._reader.join(timeout=10)
            self.proc.stderr.close()
            shutil.rmtree(self.data_dir, ignore_errors=True)
