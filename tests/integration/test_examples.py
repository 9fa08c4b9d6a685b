"""client/examples/ against a real server: the Go example built offline from Debian's packages
(client/examples/go/build.sh) and the Python example with stubs from generate.sh, each
registering a container, estimating a scan, paging through the containers and decoding an
error's google.rpc.Status details. Each must print what the server answered."""
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import SKIPPED, Server, needs_own_server  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
EXAMPLES = os.path.join(ROOT, "client", "examples")
TOOLS = ["go", "protoc", "protoc-gen-go", "protoc-gen-go-grpc", "grpc_python_plugin"]
missing = [tool for tool in TOOLS if shutil.which(tool) is None]
if missing:
    print(f"skipped: {', '.join(missing)} not installed (scripts/install-deps.sh test)",
          file=sys.stderr)
    sys.exit(1 if os.environ.get("SOILVOL_REQUIRE_TOOLS") == "1" else SKIPPED)
TOLERANCE_L = 0.04 * box_scene.STRUCK_M3 * 1000


@needs_own_server
class Examples(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="soilvol-examples-")
        cls.server = Server(args=["--workers", "2"]).start()
        cls.empty = os.path.join(cls.dir, "empty.ply")
        cls.scan = os.path.join(cls.dir, "scan.ply")
        with open(cls.empty, "wb") as f:
            f.write(box_scene.encode_ply(box_scene.box_scan(0.0, seed=1)))
        with open(cls.scan, "wb") as f:
            f.write(box_scene.encode_ply(box_scene.box_scan(0.25, seed=2, shift=(0.02, 0.01, 0.0),
                                                            yaw_deg=1.5)))
        cls.corners = ";".join(f"{x},{y},{z}" for x, y, z in box_scene.opening_corners())
        cls.truth_l = 1000 * box_scene.INNER_L * box_scene.INNER_W * 0.25

    @classmethod
    def tearDownClass(cls):
        cls.server.close()
        shutil.rmtree(cls.dir, ignore_errors=True)

    def check_output(self, out, container_id):
        self.assertRegex(out, r"server \d+\.\d+\.\d+ ")
        self.assertIn(f"registered {container_id}: struck capacity", out)
        volume = float(re.search(r"volume ([0-9.]+) L", out).group(1))
        self.assertLess(abs(volume - self.truth_l), TOLERANCE_L, out)
        self.assertRegex(out, r"containers: [1-9]")
        self.assertIn("INVALID_ARGUMENT", out.replace("InvalidArgument", "INVALID_ARGUMENT"))
        self.assertIn("reason INVALID_ARGUMENT (domain soilvol)", out)
        self.assertIn("bad field grid_cell_m", out)

    def run_example(self, cmd, env=None):
        result = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
        return result.stdout

    def test_go_example(self):
        out_dir = os.path.join(self.dir, "go")
        self.run_example([os.path.join(EXAMPLES, "go", "build.sh"), out_dir])
        out = self.run_example([os.path.join(out_dir, "soilvol-go-example"),
                                "-server", self.server.grpc_target, "-id", "go-box",
                                "-empty", self.empty, f"-corners={self.corners}",
                                "-scan", self.scan])
        self.check_output(out, "go-box")

    def test_python_example(self):
        stubs = os.path.join(self.dir, "python")
        self.run_example([os.path.join(EXAMPLES, "python", "generate.sh"), stubs])
        env = dict(os.environ, PYTHONPATH=stubs)
        out = self.run_example(["/usr/bin/python3",
                                os.path.join(EXAMPLES, "python", "soilvol_example.py"),
                                "--server", self.server.grpc_target, "--id", "py-box",
                                "--empty", self.empty, f"--corners={self.corners}",
                                "--scan", self.scan], env=env)
        self.check_output(out, "py-box")


if __name__ == "__main__":
    unittest.main(verbosity=2)
