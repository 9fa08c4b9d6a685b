"""The README's shell recipes against a real server: every ```sh block of README.md runs, in
order, as `bash -euo pipefail`, and each must succeed. A block right after the line
`<!-- readme-test: skip: <reason> -->` is left out (installers, commands that never end).

The blocks run as a reader runs them beside `scripts/run.sh`: in a scratch folder holding a link
to every top-level entry of the repository (so `tokens` and other files a recipe writes stay
there) and `build` linked to the build under test, with a server started as run.sh starts it
(`soilvol demo --keep` registers demo-paper first). Only addresses and /tmp are substituted:
`localhost:8080` and `localhost:50051` become the server's ports, the second servers' 8443,
50443, 8444, 50444 and the webhook receiver's 9000 free ones, `/tmp/` the scratch folder's `tmp/`. On PATH first: the npm tools (as the README
says to export) and a `curl` that adds --fail-with-body, so that an HTTP error fails the recipe."""
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(__file__))
from harness import CLI_BIN, SERVER_BIN, SKIPPED, TIME_SCALE, Server, needs_own_server  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
README = os.path.join(ROOT, "README.md")
TOOLS = os.environ.get("SOILVOL_TOOLS_DIR", os.path.expanduser("~/.cache/soilvol-tools"))
SKIP = re.compile(r"^\s*<!-- readme-test: skip: .+ -->\s*$")
FENCE = re.compile(r"^(\s*)```(\S*)\s*$")

missing = [tool for tool in ("curl", "openssl", "go", "protoc-gen-go", "grpc_python_plugin")
           if shutil.which(tool) is None]
if not os.access(os.path.join(TOOLS, "node_modules", ".bin", "buf"), os.X_OK):
    missing.append("buf")
if missing:
    print(f"skipped: {', '.join(missing)} not installed (scripts/install-deps.sh test, "
          "scripts/install-test-tools.sh)", file=sys.stderr)
    sys.exit(1 if os.environ.get("SOILVOL_REQUIRE_TOOLS") == "1" else SKIPPED)


def shell_blocks(path):
    """[(line number, text)] of the ```sh blocks not marked to skip, their indentation removed."""
    blocks, lines = [], open(path).read().split("\n")
    i = 0
    while i < len(lines):
        fence = FENCE.match(lines[i])
        if not fence:
            i += 1
            continue
        end = i + 1
        while end < len(lines) and not FENCE.match(lines[end]):
            end += 1
        indent = len(fence.group(1))
        skipped = i > 0 and SKIP.match(lines[i - 1])
        if fence.group(2) == "sh" and not skipped:
            blocks.append((i + 1, "\n".join(line[indent:] for line in lines[i + 1:end])))
        i = end + 1
    return blocks


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@needs_own_server
class Readme(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="soilvol-readme-")
        for name in os.listdir(ROOT):
            if name not in (".git", "build"):
                os.symlink(os.path.join(ROOT, name), os.path.join(cls.dir, name))
        build = os.path.dirname(os.path.dirname(os.path.abspath(SERVER_BIN)))
        os.symlink(build, os.path.join(cls.dir, "build"))
        os.makedirs(os.path.join(cls.dir, "tmp"))
        os.makedirs(os.path.join(cls.dir, "bin"))
        with open(os.path.join(cls.dir, "bin", "curl"), "w") as f:
            f.write(f"#!/bin/sh\nexec {shutil.which('curl')} --fail-with-body \"$@\"\n")
        os.chmod(os.path.join(cls.dir, "bin", "curl"), 0o755)
        cls.server = Server(args=["--workers", "2"]).start()
        cls.ports = {port: free_port() for port in ("8443", "50443", "8444", "50444", "9000")}
        cls.env = dict(os.environ, SOILVOL_SERVER=cls.server.grpc_target,
                       PATH=os.pathsep.join([os.path.join(cls.dir, "bin"),
                                             os.path.join(TOOLS, "node_modules", ".bin"),
                                             os.environ["PATH"]]),
                       HOME=os.environ.get("HOME", cls.dir))
        cls.env.pop("SOILVOL_TOKEN", None)
        demo = subprocess.run([os.path.abspath(CLI_BIN), "demo", "--keep"], env=cls.env,
                              capture_output=True, text=True, timeout=300 * TIME_SCALE)
        assert demo.returncode == 0, demo.stdout + demo.stderr
        cls.groups = []

    @classmethod
    def tearDownClass(cls):
        for group in cls.groups:  # what the recipes left running (watchers, a second server)
            try:
                os.killpg(group, signal.SIGTERM)
            except ProcessLookupError:
                pass
        cls.server.close()
        shutil.rmtree(cls.dir, ignore_errors=True)

    def substitute(self, text):
        text = text.replace("localhost:8080", f"127.0.0.1:{self.server.http_port}")
        text = text.replace("localhost:50051", self.server.grpc_target)
        for port, free in self.ports.items():
            text = re.sub(rf"(localhost|0\.0\.0\.0):{port}\b", rf"\g<1>:{free}", text)
        return re.sub(r"(?<![\w.])/tmp/", os.path.join(self.dir, "tmp") + "/", text)

    def test_every_shell_block_runs(self):
        blocks = shell_blocks(README)
        self.assertGreaterEqual(len(blocks), 8)
        for line, text in blocks:
            with self.subTest(f"README.md:{line}"):
                log = os.path.join(self.dir, f"block-{line}.log")
                with open(log, "w") as out:
                    shell = subprocess.Popen(["bash", "-euo", "pipefail", "-c",
                                              self.substitute(text)],
                                             cwd=self.dir, env=self.env, stdout=out,
                                             stderr=subprocess.STDOUT, start_new_session=True)
                    self.groups.append(shell.pid)
                    try:
                        code = shell.wait(timeout=600 * TIME_SCALE)
                    except subprocess.TimeoutExpired:
                        code = "timeout"
                with open(log) as f:
                    output = f.read()
                self.assertEqual(code, 0, f"README.md:{line}\n{self.substitute(text)}\n"
                                          f"--- output\n{output[-4000:]}")


if __name__ == "__main__":
    unittest.main(verbosity=2)
