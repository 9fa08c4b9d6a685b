"""Depth images end to end, over REST (binary body with the camera in the query, multipart with
a confidence image, JSON) and gRPC: a box rendered by numpy ray casting (depth_scene.py), not
by soilvol's simulator. A depth image gives the volume its back-projected cloud gives, registers
as well as a cloud does, and hostile images and cameras are refused naming the field."""
import json
import os
import shutil
import sys
import tempfile
import unittest
import urllib.parse

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
import depth_scene  # noqa: E402
from harness import (CURL, SKIPPED, b64, corners_json, curl_json, load_grpc,  # noqa: E402
                     shared_server, write_file)

grpc, pb, pb_grpc = load_grpc()
if CURL is None:
    print("skipped: curl is not installed", file=sys.stderr)
    sys.exit(1 if os.environ.get("SOILVOL_REQUIRE_TOOLS") else SKIPPED)

TOLERANCE_OF_STRUCK = 0.04  # the cloud suites' bound for a 1 cm grid of returns
SAME_AS_CLOUD_OF_STRUCK = 0.0001  # issue 29: the depth image gives its cloud's volume
NOISE_M = 0.002


def camera_query(prefix="scan.depth.camera."):
    return {prefix + k: v for k, v in depth_scene.intrinsics().items()}


class DepthImages(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = shared_server()
        cls.channel = cls.server.channel(grpc)
        cls.stub = pb_grpc.SoilVolumeStub(cls.channel)
        cls.dir = tempfile.mkdtemp(prefix="soilvol-depth-")
        cls.opening = json.dumps(corners_json(depth_scene.opening_corners()))
        empty = depth_scene.millimetres(depth_scene.render(0.0, NOISE_M, seed=1))
        cls.empty_png = cls.write("empty.png", depth_scene.encode_png(empty))
        query = urllib.parse.urlencode({"containerId": "depth-box", "overwrite": "true",
                                        "opening": cls.opening, "file": "depth",
                                        **camera_query()})
        status, container = curl_json(cls.server, f"/v1/containers?{query}", "--data-binary",
                                      f"@{cls.empty_png}",
                                      "-H", "Content-Type: application/octet-stream")
        assert status == 200, container
        cls.container = container

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        shutil.rmtree(cls.dir, ignore_errors=True)
        cls.server.close()

    @classmethod
    def write(cls, name, data):
        return write_file(cls.dir, name, data)

    def estimate(self, path_query, *args):
        return curl_json(self.server, f"/v1/containers/depth-box:estimate?{path_query}", *args)

    def test_registered_from_a_depth_image(self):
        self.assertEqual(self.container["registeredFrom"], "SCAN_KIND_DEPTH")
        self.assertLess(abs(self.container["struckCapacityM3"] - box_scene.STRUCK_M3),
                        0.02 * box_scene.STRUCK_M3)

    def test_binary_depth_image_gives_its_clouds_volume(self):
        z_mm = depth_scene.millimetres(depth_scene.render(0.2, NOISE_M, seed=2))
        png = self.write("fill.png", depth_scene.encode_png(z_mm))
        # The same returns as a cloud, back-projected by numpy float for float as core does:
        # the engine's answer moves by about 0.02% of struck when its points move by float
        # rounding (1e-7), so only the same floats can show that the two paths agree.
        ply = self.write("fill.ply", box_scene.encode_ply(depth_scene.back_project_as_core(z_mm)))
        query = urllib.parse.urlencode({"file": "depth", "skipRecord": "true",
                                        "scan.depth.keepFlyingPixels": "true", **camera_query()})
        status, from_depth = self.estimate(query, "--data-binary", f"@{png}",
                                           "-H", "Content-Type: application/octet-stream")
        self.assertEqual(status, 200, from_depth)
        status, from_cloud = self.estimate("skipRecord=true", "--data-binary", f"@{ply}",
                                           "-H", "Content-Type: application/octet-stream")
        self.assertEqual(status, 200, from_cloud)
        pixels = from_depth["depthPixels"]
        self.assertEqual(int(pixels["pixels"]), depth_scene.WIDTH * depth_scene.HEIGHT)
        self.assertEqual(int(pixels["points"]), from_cloud["scanPoints"])
        self.assertEqual(from_depth["scanPoints"], from_cloud["scanPoints"])
        self.assertLess(abs(from_depth["volumeM3"] - from_cloud["volumeM3"]),
                        SAME_AS_CLOUD_OF_STRUCK * box_scene.STRUCK_M3)
        truth = box_scene.INNER_L * box_scene.INNER_W * 0.2
        self.assertLess(abs(from_depth["volumeM3"] - truth),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3)
        # With the flying-pixel filter on (the render has no mixed pixels): at most 0.5% of
        # the returns go, and the volume stays within 0.1% of struck.
        query = urllib.parse.urlencode({"file": "depth", "skipRecord": "true", **camera_query()})
        status, filtered = self.estimate(query, "--data-binary", f"@{png}",
                                         "-H", "Content-Type: application/octet-stream")
        self.assertEqual(status, 200, filtered)
        self.assertLessEqual(int(filtered["depthPixels"].get("flying", 0)),
                             0.005 * int(pixels["points"]))
        self.assertLess(abs(filtered["volumeM3"] - from_depth["volumeM3"]),
                        0.001 * box_scene.STRUCK_M3)

    def test_float_tiff_with_a_confidence_image_by_multipart(self):
        z = depth_scene.render(0.3, NOISE_M, seed=3).astype(np.float32)
        confidence = np.full(z.shape, 200, np.uint8)
        confidence[:, :40] = 10  # a dim left band: dropped
        tiff = self.write("fill.tiff", depth_scene.encode_float_tiff(z))
        conf = self.write("confidence.png", depth_scene.encode_png(confidence))
        request = {"skipRecord": True,
                   "scan": {"depth": {"minConfidence": 50, "camera": depth_scene.intrinsics()}}}
        status, est = self.estimate("", "-F", f"depth=@{tiff}", "-F", f"confidence=@{conf}",
                                    "-F", "request=" + json.dumps(request))
        self.assertEqual(status, 200, est)
        self.assertEqual(int(est["depthPixels"]["lowConfidence"]), 40 * depth_scene.HEIGHT)
        truth = box_scene.INNER_L * box_scene.INNER_W * 0.3
        self.assertLess(abs(est["volumeM3"] - truth), TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3)

    def test_grpc_and_json_carry_the_same_scan(self):
        z_mm = depth_scene.millimetres(depth_scene.render(0.1, NOISE_M, seed=4))
        png = depth_scene.encode_png(z_mm)
        camera = pb.DepthCamera(**depth_scene.intrinsics())
        request = pb.EstimateVolumeRequest(
            container_id="depth-box", skip_record=True,
            scan=pb.Scan(depth=pb.DepthScan(depth=png, camera=camera)))
        over_grpc = self.stub.EstimateVolume(request, timeout=60)
        body = json.dumps({"skipRecord": True, "scan": {"depth": {
            "depth": b64(png), "camera": depth_scene.intrinsics()}}})
        status, over_json = self.estimate("", "-H", "Content-Type: application/json",
                                          "-d", body)
        self.assertEqual(status, 200, over_json)
        self.assertAlmostEqual(over_grpc.volume_m3, over_json["volumeM3"], places=9)
        self.assertEqual(over_grpc.depth_pixels.points, int(over_json["depthPixels"]["points"]))
        truth = box_scene.INNER_L * box_scene.INNER_W * 0.1
        self.assertLess(abs(over_grpc.volume_m3 - truth),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3)

    def test_hostile_images_and_cameras_name_the_field(self):
        z_mm = depth_scene.millimetres(depth_scene.render(0.1, 0.0, seed=5))
        good = self.write("good.png", depth_scene.encode_png(z_mm))
        grey8 = self.write("grey8.png", depth_scene.encode_png((z_mm // 16).astype(np.uint8)))
        huge = bytearray(depth_scene.encode_png(np.zeros((4, 4), np.uint16)))
        huge[16:20] = (1 << 20).to_bytes(4, "big")  # a header declaring 1M px a side
        huge = self.write("huge.png", bytes(huge))
        garbage = self.write("garbage.png", os.urandom(3000))
        binary = ["-H", "Content-Type: application/octet-stream"]

        def query(**extra):
            return urllib.parse.urlencode({"file": "depth", "skipRecord": "true",
                                           **camera_query(), **extra})

        cases = [
            ("8-bit depth", query(), ["--data-binary", f"@{grey8}", *binary],
             "scan.depth.depth: 8-bit samples"),
            ("declared size over the budget", query(), ["--data-binary", f"@{huge}", *binary],
             "scan.depth.depth: 1048576x4 is larger than"),
            ("not an image", query(), ["--data-binary", f"@{garbage}", *binary],
             "scan.depth.depth: not a decodable image"),
            ("no intrinsics", "file=depth", ["--data-binary", f"@{good}", *binary],
             "scan.depth.camera.fx/fy"),
            ("unknown lens", query(**{"scan.depth.camera.lens": "7"}),
             ["--data-binary", f"@{good}", *binary], "scan.depth.camera.lens"),
            ("coefficients the lens does not take",
             query(**{"scan.depth.camera.lens": "LENS_MODEL_KANNALA_BRANDT"}),
             ["--data-binary", f"@{good}", *binary], "scan.depth.camera.distortion: 0"),
            ("negative noise", query(**{"scan.depth.depthNoiseM": "-1"}),
             ["--data-binary", f"@{good}", *binary], "scan.depth.depth_noise_m"),
            ("confidence alone as a binary body", "file=confidence",
             ["--data-binary", f"@{good}", *binary], "file: 'confidence' is not cloud, depth"),
            ("an 8-bit confidence image of the depth image's size is fine", "skipRecord=true",
             ["-F", f"depth=@{good}", "-F", f"confidence=@{grey8}",
              "-F", "request=" + json.dumps({"scan": {"depth": {
                  "camera": depth_scene.intrinsics()}}})], None),
        ]
        for name, q, args, fragment in cases:
            with self.subTest(name):
                status, err = self.estimate(q, *args)
                if fragment is None:
                    self.assertEqual(status, 200, err)
                    continue
                self.assertEqual(status, 400, f"{name}: {err}")
                self.assertIn(fragment, err["message"], name)
        small = self.write("small.png", depth_scene.encode_png(np.full((10, 10), 9, np.uint8)))
        status, err = self.estimate("", "-F", f"depth=@{good}", "-F", f"confidence=@{small}",
                                    "-F", "request=" + json.dumps({"scan": {"depth": {
                                        "camera": depth_scene.intrinsics()}}}))
        self.assertEqual(status, 400, err)
        self.assertIn("scan.depth.confidence: 10x10 does not match", err["message"])
        with self.assertRaises(grpc.RpcError) as raised:
            self.stub.EstimateVolume(pb.EstimateVolumeRequest(
                container_id="depth-box", skip_record=True,
                scan=pb.Scan(depth=pb.DepthScan(depth=b"\x89PNG", camera=pb.DepthCamera(
                    **depth_scene.intrinsics())))), timeout=60)
        self.assertEqual(raised.exception.code(), grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("scan.depth.depth", raised.exception.details())
        self.assertEqual(curl_json(self.server, "/healthz")[0], 200)


if __name__ == "__main__":
    unittest.main(verbosity=2)
