"""Binary uploads on REST, by the real curl binary as the README shows them: a raw PLY body
(application/octet-stream, parameters in the query) and multipart/form-data (a cloud file, or a
request part and files), for RegisterContainer and EstimateVolume, up to a 10 MB scan."""
import json
import os
import shutil
import sys
import tempfile
import unittest
import urllib.parse

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import CURL, SKIPPED, corners_json, curl_json, shared_server, write_file  # noqa: E402

TOLERANCE_OF_STRUCK = 0.04
if CURL is None:
    print("skipped: curl is not installed", file=sys.stderr)
    sys.exit(1 if os.environ.get("SOILVOL_REQUIRE_TOOLS") else SKIPPED)


def truth_m3(fill):
    return box_scene.INNER_L * box_scene.INNER_W * fill


class Uploads(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = shared_server()
        cls.dir = tempfile.mkdtemp(prefix="soilvol-uploads-")
        cls.empty = cls.write("empty.ply", box_scene.encode_ply(box_scene.box_scan(0.0, seed=1)))
        cls.opening = json.dumps(corners_json(box_scene.opening_corners()))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)
        cls.server.close()

    @classmethod
    def write(cls, name, data):
        return write_file(cls.dir, name, data)

    def curl(self, path, *args):
        """(HTTP status, parsed JSON) of `curl <args> <server><path>`."""
        return curl_json(self.server, path, *args)

    def register_binary(self, cid):
        query = urllib.parse.urlencode({"containerId": cid, "overwrite": "true",
                                        "opening": self.opening})
        return self.curl(f"/v1/containers?{query}", "--data-binary", f"@{self.empty}",
                         "-H", "Content-Type: application/octet-stream")

    def test_binary_register_and_a_10_mb_estimate(self):
        status, container = self.register_binary("upload-bin")
        self.assertEqual(status, 200, container)
        self.assertEqual(container["containerId"], "upload-bin")
        # A dense scan: 0.0017 m spacing, about 870k points, over 10 MB of binary PLY.
        dense = box_scene.encode_ply(box_scene.box_scan(0.3, seed=2, step=0.0017,
                                                        shift=(0.02, -0.01, 0.0), yaw_deg=1.0))
        self.assertGreater(len(dense), 10_000_000)
        path = self.write("dense.ply", dense)
        status, est = self.curl("/v1/containers/upload-bin:estimate?gridCellM=0.05&requestId=big-1",
                                "--data-binary", f"@{path}",
                                "-H", "Content-Type: application/octet-stream")
        self.assertEqual(status, 200, est)
        self.assertEqual(est["requestId"], "big-1")
        self.assertEqual(est["cells"]["cellM"], 0.05)
        self.assertGreater(est["scanPoints"], 800_000)
        self.assertLess(abs(est["volumeM3"] - truth_m3(0.3)),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3)

    def test_multipart_register_and_estimate(self):
        status, container = self.curl("/v1/containers", "-F", f"cloud=@{self.empty}",
                                       "-F", "request={\"containerId\": \"upload-mp\", "
                                             "\"overwrite\": true, \"opening\": " + self.opening + "}")
        self.assertEqual(status, 200, container)
        self.assertEqual(container["containerId"], "upload-mp")
        scan = self.write("fill.ply", box_scene.encode_ply(
            box_scene.box_scan(0.2, seed=3, shift=(0.03, -0.02, 0.01), yaw_deg=2.0)))
        # A browser form: the file and the other fields as their own parts.
        status, est = self.curl("/v1/containers/upload-mp:estimate", "-F", f"cloud=@{scan}",
                                "-F", "materialDensityKgM3=1600",
                                "-F", "method=ESTIMATION_METHOD_HEIGHTMAP")
        self.assertEqual(status, 200, est)
        self.assertLess(abs(est["volumeM3"] - truth_m3(0.2)),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3)
        self.assertAlmostEqual(est["massKg"], 1600 * est["volumeM3"], places=6)

    def test_bad_uploads_name_what_is_wrong(self):
        self.assertEqual(self.register_binary("upload-bad")[0], 200)
        scan = self.write("small.ply", box_scene.encode_ply(box_scene.box_scan(0.1, seed=4)))
        cases = [
            ("unknown query parameter", 400, "gridCel",
             ["/v1/containers/upload-bad:estimate?gridCel=0.05", "--data-binary", f"@{scan}",
              "-H", "Content-Type: application/octet-stream"]),
            ("bytes from the query", 400, "scan.cloud.data",
             ["/v1/containers/upload-bad:estimate?scan.cloud.data=abc", "--data-binary",
              f"@{scan}", "-H", "Content-Type: application/octet-stream"]),
            ("garbage file", 400, "scan.cloud.data",
             ["/v1/containers/upload-bad:estimate", "--data-binary", "@/dev/null",
              "-H", "Content-Type: application/octet-stream"]),
            ("binary body for a route without a scan", 400, "octet-stream",
             ["/v1/calibrations", "--data-binary", f"@{scan}",
              "-H", "Content-Type: application/octet-stream"]),
            ("file part twice", 400, "twice",
             ["/v1/containers/upload-bad:estimate", "-F", f"cloud=@{scan}", "-F", f"cloud=@{scan}"]),
            ("cloud in the request and as a file", 400, "scan.cloud.data",
             ["/v1/containers/upload-bad:estimate", "-F", f"cloud=@{scan}",
              "-F", "request={\"scan\": {\"cloud\": {\"data\": \"cGx5\"}}}"]),
            ("unknown part", 400, "nope",
             ["/v1/containers/upload-bad:estimate", "-F", f"cloud=@{scan}", "-F", "nope=1"]),
            ("multipart without a boundary", 415, "boundary",
             ["/v1/containers/upload-bad:estimate", "--data-binary", f"@{scan}",
              "-H", "Content-Type: multipart/form-data"]),
            ("text/plain", 415, "Content-Type",
             ["/v1/containers/upload-bad:estimate", "--data-binary", f"@{scan}",
              "-H", "Content-Type: text/plain"]),
            ("a form body (curl -d's default type)", 415, "curl -d",
             ["/v1/containers/upload-bad", "-X", "PATCH", "-d", '{"displayName": "x"}']),
            ("truncated multipart", 400, "multipart body",
             ["/v1/containers/upload-bad:estimate", "--data-binary",
              "--XyZ\r\nContent-Disposition: form-data; name=\"cloud\"\r\n\r\nply",
              "-H", "Content-Type: multipart/form-data; boundary=XyZ"]),
        ]
        for name, code, fragment, args in cases:
            with self.subTest(name):
                status, err = self.curl(*args)
                self.assertEqual(status, code, f"{name}: {err}")
                self.assertIn(fragment, err["message"], name)
        # A body without a Content-Type is JSON (grpc-gateway's default).
        status, patched = self.curl("/v1/containers/upload-bad", "-X", "PATCH",
                                    "-H", "Content-Type:", "-d", '{"displayName": "Untyped"}')
        self.assertEqual(status, 200, patched)
        self.assertEqual(patched["displayName"], "Untyped")
        self.assertEqual(self.curl("/healthz")[0], 200)


if __name__ == "__main__":
    unittest.main(verbosity=2)
