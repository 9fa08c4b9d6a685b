"""A third-party gRPC client against a real server: `buf curl`, with the schema from server
reflection only (no proto files are given to buf). buf comes from npm (@bufbuild/buf, see
scripts/install-test-tools.sh); the test is skipped (exit 77) when it is not installed."""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import SKIPPED, cloud_scan, corners_json, shared_server  # noqa: E402

TOLERANCE_OF_STRUCK = 0.04  # as test_rest.py
PROTO = os.path.join(os.path.dirname(__file__), "..", "..", "proto", "soilvol", "v1",
                     "soilvol.proto")
# buf curl exits with the gRPC status code shifted left by three bits when the RPC fails.
NOT_FOUND_EXIT, INVALID_ARGUMENT_EXIT = 5 << 3, 3 << 3


def find_buf():
    tools = os.environ.get("SOILVOL_TOOLS_DIR", os.path.expanduser("~/.cache/soilvol-tools"))
    local = os.path.join(tools, "node_modules", ".bin", "buf")
    if os.access(local, os.X_OK):
        return local
    return shutil.which("buf")


BUF = find_buf()
if BUF is None:
    print("skipped: buf not found on PATH or in $SOILVOL_TOOLS_DIR/node_modules/.bin "
          "(run scripts/install-test-tools.sh)", file=sys.stderr)
    sys.exit(SKIPPED)


def proto_methods():
    with open(PROTO) as f:
        return {f"soilvol.v1.SoilVolume/{name}" for name in re.findall(r"\brpc\s+(\w+)\s*\(",
                                                                        f.read())}


class BufCurl(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="soilvol-buf-")
        cls.env = dict(os.environ, BUF_CACHE_DIR=os.path.join(cls.tmp, "cache"))
        version = subprocess.run([BUF, "--version"], capture_output=True, text=True,
                                 env=cls.env, timeout=60)
        if version.returncode != 0:
            raise RuntimeError(f"{BUF} does not run: {version.stderr}")
        cls.server = shared_server()
        # A secured server: TLS with its CA and the suite's bearer token, through reflection too.
        secure = bool(getattr(cls.server, "tls_ca", None))
        cls.url = f"{'https' if secure else 'http'}://{cls.server.grpc_target}"
        cls.transport = (["--cacert", cls.server.tls_ca] if secure
                         else ["--http2-prior-knowledge"])
        if cls.server.token:
            cls.transport += ["-H", f"Authorization: Bearer {cls.server.token}",
                              "--reflect-header", f"Authorization: Bearer {cls.server.token}"]

    @classmethod
    def tearDownClass(cls):
        cls.server.close()
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def buf(self, *args):
        """(exit code, stdout, stderr) of one buf curl over gRPC with reflection."""
        cmd = [BUF, "curl", "--protocol", "grpc", *self.transport, "--timeout", "60s", *args]
        done = subprocess.run(cmd, capture_output=True, text=True, env=self.env, timeout=120)
        return done.returncode, done.stdout, done.stderr

    def call(self, method, body):
        """The JSON answer of a successful call; `body` goes through a file (-d @file)."""
        path = os.path.join(self.tmp, "request.json")
        with open(path, "w") as f:
            if isinstance(body, list):  # several messages for a streaming call
                f.write("\n".join(json.dumps(b) for b in body))
            else:
                json.dump(body, f)
        code, out, err = self.buf(f"{self.url}/{method}", "-d", f"@{path}")
        self.assertEqual(code, 0, err)
        return out

    def register(self, cid):
        body = {"containerId": cid, "scan": cloud_scan(box_scene.encode_ply(
                    box_scene.box_scan(0.0, seed=1))),
                "opening": corners_json(box_scene.opening_corners())}
        return json.loads(self.call("soilvol.v1.SoilVolume/RegisterContainer", body))

    def estimate_body(self, cid, fill, **extra):
        scan = box_scene.encode_ply(box_scene.box_scan(fill, seed=11, shift=(0.03, -0.02, 0.01),
                                                       yaw_deg=2.0))
        return dict({"containerId": cid, "scan": cloud_scan(scan)}, **extra)

    def assert_volume(self, answer, fill):
        truth = box_scene.INNER_L * box_scene.INNER_W * fill
        self.assertLess(abs(answer["volumeM3"] - truth), TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3,
                        f"fill {fill}: {answer['volumeM3']} vs {truth}")

    def test_reflection_lists_every_method(self):
        code, out, err = self.buf("--list-methods", self.url)
        self.assertEqual(code, 0, err)
        listed = set(out.split())
        self.assertEqual({m for m in listed if m.startswith("soilvol.")}, proto_methods())
        self.assertGreaterEqual(len(proto_methods()), 12)  # the proto file was found
        self.assertIn("grpc.health.v1.Health/Check", listed)
        self.assertIn("grpc.health.v1.Health/Watch", listed)

    def test_register_list_estimate(self):
        container = self.register("buf-box")
        self.assertEqual(container["containerId"], "buf-box")
        self.assertEqual(container["registeredFrom"], "SCAN_KIND_CLOUD")
        self.assertAlmostEqual(container["struckCapacityM3"], box_scene.STRUCK_M3,
                               delta=0.02 * box_scene.STRUCK_M3)
        self.assertGreater(int(container["scanPoints"]), 10000)  # int64: a JSON string

        code, out, err = self.buf(f"{self.url}/soilvol.v1.SoilVolume/ListContainers", "-d", "{}")
        self.assertEqual(code, 0, err)
        self.assertIn("buf-box", [c["containerId"] for c in json.loads(out)["containers"]])

        answer = json.loads(self.call("soilvol.v1.SoilVolume/EstimateVolume",
                                      self.estimate_body("buf-box", 0.3, requestId="r1",
                                                         materialDensityKgM3=1600)))
        self.assert_volume(answer, 0.3)
        self.assertEqual(answer["requestId"], "r1")
        self.assertAlmostEqual(answer["massKg"], 1600 * answer["volumeM3"], places=6)

    def test_stream_estimates(self):
        self.register("buf-stream")
        fills = [0.1, 0.35, 0.2]
        out = self.call("soilvol.v1.SoilVolume/StreamEstimates",
                        [self.estimate_body("buf-stream", fill, requestId=f"s{i}")
                         for i, fill in enumerate(fills)])
        answers, decoder, at = [], json.JSONDecoder(), 0
        while out[at:].strip():  # one JSON document per answer
            at += len(out[at:]) - len(out[at:].lstrip())
            answer, at = decoder.raw_decode(out, at)
            answers.append(answer)
        self.assertEqual([a["requestId"] for a in answers], ["s0", "s1", "s2"])
        self.assertEqual([int(a.get("sequence", 0)) for a in answers], [0, 1, 2])
        for answer, fill in zip(answers, fills):
            self.assert_volume(answer["estimate"], fill)

    def test_errors_exit_with_the_status_code(self):
        code, out, err = self.buf(f"{self.url}/soilvol.v1.SoilVolume/GetContainer",
                                  "-d", '{"containerId": "nope"}')
        self.assertEqual(code, NOT_FOUND_EXIT, out + err)
        self.assertIn("not_found", err)
        self.assertIn("nope", err)
        code, out, err = self.buf(f"{self.url}/soilvol.v1.SoilVolume/GetContainer",
                                  "-d", '{"containerId": "../x"}')
        self.assertEqual(code, INVALID_ARGUMENT_EXIT, out + err)
        self.assertIn("container_id", err)

    def test_health(self):
        code, out, err = self.buf(f"{self.url}/grpc.health.v1.Health/Check", "-d", "{}")
        self.assertEqual(code, 0, err)
        self.assertEqual(json.loads(out), {"status": "SERVING"})
        code, out, err = self.buf(f"{self.url}/grpc.health.v1.Health/Check",
                                  "-d", '{"service": "liveness"}')
        self.assertEqual((code, json.loads(out)), (0, {"status": "SERVING"}), err)
        code, out, err = self.buf(f"{self.url}/grpc.health.v1.Health/Check",
                                  "-d", '{"service": "nope"}')
        self.assertEqual(code, NOT_FOUND_EXIT, out + err)


if __name__ == "__main__":
    unittest.main(verbosity=2)
