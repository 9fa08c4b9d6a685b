"""The OpenAPI document by independent tools (npm, pinned in scripts/install-test-tools.sh):
the committed document is what scripts/gen-openapi.sh makes from the proto (drift check); the
served one is the committed one and passes @apidevtools/swagger-parser's validation (the OpenAPI
3.0 schema and its semantic rules); a client generated from it (openapi-typescript types,
openapi-fetch calls, tsc --strict) registers, estimates, reads, lists, patches and deletes on a
live server and reads an error as google.rpc.Status. Skipped (exit 77) without the tools, an
error under SOILVOL_REQUIRE_TOOLS=1 (CI)."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import SKIPPED, shared_server  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
TOOLS = os.environ.get("SOILVOL_TOOLS_DIR", os.path.expanduser("~/.cache/soilvol-tools"))
MODULES = os.path.join(TOOLS, "node_modules")
CLIENT = os.path.join(os.path.dirname(__file__), "openapi_client")
COMMITTED = os.path.join(ROOT, "proto", "openapi", "soilvol.v1.openapi.json")
TOLERANCE_OF_STRUCK = 0.04  # as test_rest.py

missing = [tool for tool in ("node", "protoc", "protoc-gen-swagger") if shutil.which(tool) is None]
missing += [m for m in ("swagger2openapi", "@apidevtools/swagger-parser", "openapi-typescript",
                        "openapi-fetch", "typescript", "@types/node")
            if not os.path.isdir(os.path.join(MODULES, m))]
if missing:
    print(f"skipped: {', '.join(missing)} not installed (scripts/install-deps.sh test, "
          "scripts/install-test-tools.sh)", file=sys.stderr)
    sys.exit(1 if os.environ.get("SOILVOL_REQUIRE_TOOLS") == "1" else SKIPPED)


def run(args, **kwargs):
    return subprocess.run(args, capture_output=True, text=True, timeout=300, **kwargs)


class Contract(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="soilvol-openapi-")
        cls.server = shared_server()
        status, cls.served = cls.server.rest("GET", "/openapi.json",
                                             headers={"Authorization": None})
        assert status == 200, (status, cls.served)
        cls.doc = os.path.join(cls.dir, "openapi.json")
        with open(cls.doc, "w") as f:
            json.dump(cls.served, f)

    @classmethod
    def tearDownClass(cls):
        cls.server.close()
        shutil.rmtree(cls.dir, ignore_errors=True)

    def test_committed_document_is_what_the_proto_makes(self):
        check = run([os.path.join(ROOT, "scripts", "gen-openapi.sh"), "--check"],
                    env=dict(os.environ, SOILVOL_TOOLS_DIR=TOOLS))
        self.assertEqual(check.returncode, 0, check.stdout + check.stderr)

    def test_server_serves_the_committed_document(self):
        with open(COMMITTED) as f:
            self.assertEqual(self.served, json.load(f))

    def test_independent_validator_accepts_it(self):
        script = ("require(process.argv[1]).validate(process.argv[2]).then("
                  "(api) => console.log(`valid ${api.openapi}`), "
                  "(e) => { console.error(e.message); process.exit(1); })")
        result = run(["node", "-e", script, os.path.join(MODULES, "@apidevtools", "swagger-parser"),
                      self.doc])
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
        self.assertIn("valid 3.0", result.stdout)

    def test_generated_client_runs_against_the_server(self):
        work = os.path.join(self.dir, "client")
        os.makedirs(work)
        for name in ("client.ts", "tsconfig.json"):
            shutil.copy(os.path.join(CLIENT, name), work)
        with open(os.path.join(work, "package.json"), "w") as f:
            json.dump({"type": "module", "private": True}, f)
        os.symlink(MODULES, os.path.join(work, "node_modules"))
        bin_ = os.path.join(MODULES, ".bin")
        generated = run([os.path.join(bin_, "openapi-typescript"), self.doc, "-o",
                         os.path.join(work, "schema.d.ts")])
        self.assertEqual(generated.returncode, 0, generated.stdout + generated.stderr)
        compiled = run([os.path.join(bin_, "tsc"), "-p", work])
        self.assertEqual(compiled.returncode, 0, compiled.stdout + compiled.stderr)

        empty, scan = os.path.join(self.dir, "empty.ply"), os.path.join(self.dir, "scan.ply")
        with open(empty, "wb") as f:
            f.write(box_scene.encode_ply(box_scene.box_scan(0.0, seed=1)))
        with open(scan, "wb") as f:
            f.write(box_scene.encode_ply(box_scene.box_scan(0.3, seed=2)))
        env = dict(os.environ, SOILVOL_URL=self.server.base_url, SOILVOL_EMPTY=empty,
                   SOILVOL_SCAN=scan, SOILVOL_CONTAINER_ID="generated-client",
                   SOILVOL_CORNERS=json.dumps([{"x": x, "y": y, "z": z}
                                               for x, y, z in box_scene.opening_corners()]))
        if self.server.token:
            env["SOILVOL_TOKEN"] = self.server.token
        if getattr(self.server, "tls_ca", None):
            env["NODE_EXTRA_CA_CERTS"] = self.server.tls_ca
        result = run(["node", os.path.join(work, "out", "client.js")], env=env)
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
        out = dict(line.split("=", 1) for line in result.stdout.splitlines())
        self.assertEqual(out["registered"], "generated-client")
        self.assertAlmostEqual(float(out["struckCapacityM3"]), box_scene.STRUCK_M3,
                               delta=0.02 * box_scene.STRUCK_M3)
        truth = box_scene.INNER_L * box_scene.INNER_W * 0.3
        self.assertLess(abs(float(out["volumeM3"]) - truth),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3, out)
        self.assertGreater(float(out["fillRatio"]), 0.0)
        self.assertTrue(out["estimateId"] and out["etag"], out)
        self.assertEqual(out["listed"], "true")
        self.assertEqual(out["displayName"], "From the generated client")
        self.assertEqual(float(out["targetVolumeM3"]), 0.05)
        self.assertEqual(out["recordVolumeM3"], out["volumeM3"])
        self.assertEqual((out["errorHttp"], out["errorCode"], out["errorReason"]),
                         ("404", "5", "NOT_FOUND"))


if __name__ == "__main__":
    unittest.main(verbosity=2)
