"""What test_docker.py and test_deploy.py both need: the server's flags, the Dockerfile's
stages, and a server process started from an environment like a container's."""
import json
import os
import queue
import re
import shlex
import shutil
import signal
import subprocess
import tempfile
import threading


def port_of(address):
    return int(address.rsplit(":", 1)[1])


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


class ServerProcess:
    """soilvol-server with `env` over our environment minus its SOILVOL_* variables, on
    ephemeral loopback ports and a temporary data directory, as a container would run it."""

    def __init__(self, binary, env):
        self.data_dir = tempfile.mkdtemp(prefix="soilvol-ship-")
        full = {k: v for k, v in os.environ.items() if not k.startswith("SOILVOL_")}
        full.update(env)
        full.update(SOILVOL_GRPC_ADDRESS="127.0.0.1:0", SOILVOL_HTTP_ADDRESS="127.0.0.1:0",
                    SOILVOL_DATA_DIR=self.data_dir)
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
            if line.startswith("{"):
                fields = json.loads(line)
                if fields.get("msg") == "listening":
                    return fields
            elif " listening " in line:
                return {k: int(v) for k, v in re.findall(r"(\w+)=(\d+)\b", line)}

    def stop(self, timeout_s=30):
        """SIGTERM; the exit code. Removes the data directory."""
        self.proc.send_signal(signal.SIGTERM)
        try:
            return self.proc.wait(timeout=timeout_s)
        finally:
            self._reader.join(timeout=10)
            self.proc.stderr.close()
            shutil.rmtree(self.data_dir, ignore_errors=True)
