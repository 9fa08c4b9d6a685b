"""The REST/JSON contract, end to end against a real server process (urllib only)."""
import glob
import math
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import Server, b64, cloud_scan, corners_json, needs_own_server, shared_server  # noqa: E402

OPENCV_DATA = "/usr/share/doc/opencv-doc/examples/data"
# The box is measured to within this share of its struck capacity (independent scene, 3 mm
# noise, 2 degrees and 4 cm of motion between scans); see BENCHMARK.md for the simulator's
# figures.
TOLERANCE_OF_STRUCK = 0.04


def read_bytes(path):
    with open(path, "rb") as f:
        return f.read()


class RestFlow(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = shared_server()
        cls.empty = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))

    @classmethod
    def tearDownClass(cls):
        cls.server.close()

    def register(self, cid, overwrite=False, **extra):
        body = {"containerId": cid, "scan": cloud_scan(self.empty),
                "opening": corners_json(box_scene.opening_corners()), "overwrite": overwrite}
        body.update(extra)
        return self.server.rest("POST", "/v1/containers", body)

    def estimate(self, cid, fill, seed=7, **extra):
        scan = box_scene.encode_ply(box_scene.box_scan(fill, seed=seed, shift=(0.03, -0.02, 0.01),
                                                       yaw_deg=2.0))
        body = {"scan": cloud_scan(scan)}
        body.update(extra)
        return self.server.rest("POST", f"/v1/containers/{cid}:estimate", body)

    def test_register_get_list_estimate_delete(self):
        status, container = self.register("flow-box")
        self.assertEqual(status, 200, container)
        self.assertEqual(container["containerId"], "flow-box")
        self.assertAlmostEqual(container["struckCapacityM3"], box_scene.STRUCK_M3,
                               delta=0.02 * box_scene.STRUCK_M3)
        self.assertAlmostEqual(container["openingAreaM2"], 0.96, delta=1e-6)
        self.assertEqual(container["registeredFrom"], "SCAN_KIND_CLOUD")
        self.assertEqual(len(container["openingCorners"]), 4)

        status, got = self.server.rest("GET", "/v1/containers/flow-box")
        self.assertEqual(status, 200)
        self.assertEqual(got["struckCapacityM3"], container["struckCapacityM3"])
        status, listed = self.server.rest("GET", "/v1/containers")
        self.assertIn("flow-box", [c["containerId"] for c in listed["containers"]])

        for fill in (0.0, 0.15, 0.3, 0.5):
            status, est = self.estimate("flow-box", fill, materialDensityKgM3=1600)
            self.assertEqual(status, 200, est)
            truth = box_scene.INNER_L * box_scene.INNER_W * fill
            self.assertLess(abs(est["volumeM3"] - truth), TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3,
                            f"fill {fill}: {est['volumeM3']} vs {truth}")
            self.assertAlmostEqual(est["massKg"], 1600 * est["volumeM3"], places=6)
            self.assertAlmostEqual(est["fillRatio"] * container["struckCapacityM3"],
                                   est["volumeM3"], places=6)
            self.assertTrue(est["alignment"]["converged"])
            self.assertGreater(est["alignment"]["fitness"], 0.9)
            self.assertGreater(est["cells"]["total"], 0)
            self.assertGreater(est["timings"]["totalMs"], 0)
            self.assertGreaterEqual(est["uncertaintyM3"], 0)

        status, paper = self.estimate("flow-box", 0.3, method="ESTIMATION_METHOD_PAPER",
                                      gridCellM=0.1)
        self.assertEqual(status, 200, paper)
        self.assertEqual(paper["method"], "ESTIMATION_METHOD_PAPER")
        self.assertAlmostEqual(paper["cells"]["cellM"], 0.1)

        self.assertEqual(self.server.rest("DELETE", "/v1/containers/flow-box")[0], 200)
        status, err = self.estimate("flow-box", 0.1)
        self.assertEqual(status, 404)
        self.assertEqual(err["code"], 5)
        self.assertEqual(self.server.rest("DELETE", "/v1/containers/flow-box")[0], 404)

    def test_several_empty_scans_register_one_model(self):
        # The second view: the box moved and turned, its corners marked in that scan.
        yaw, shift = 4.0, (0.05, 0.03, 0.0)
        c, s_ = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
        moved = [(c * x - s_ * y + shift[0], s_ * x + c * y + shift[1], z + shift[2])
                 for x, y, z in box_scene.opening_corners()]
        second = box_scene.encode_ply(box_scene.box_scan(0.0, seed=3, shift=shift, yaw_deg=yaw))
        status, container = self.register(
            "two-view-box", additionalScans=[{"scan": cloud_scan(second),
                                              "opening": corners_json(moved)}])
        self.assertEqual(status, 200, container)
        self.assertEqual(container["emptyScans"], 2)
        self.assertGreater(container["observedShare"], 0.9)
        self.assertAlmostEqual(container["struckCapacityM3"], box_scene.STRUCK_M3,
                               delta=0.02 * box_scene.STRUCK_M3)
        status, est = self.estimate("two-view-box", 0.3)
        self.assertEqual(status, 200, est)
        self.assertGreater(est["coverage"]["modelObservedShare"], 0.9)
        self.assertGreater(est["coverage"]["scanObservedShare"], 0.9)
        self.assertLess(abs(est["volumeM3"] - box_scene.INNER_L * box_scene.INNER_W * 0.3),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3)
        # Too many scans, or a later one that is not a cloud, name the field.
        status, err = self.register("too-many", additionalScans=[{"scan": cloud_scan(second)}] * 8)
        self.assertEqual(status, 400, err)
        self.assertIn("additional_scans", err["message"])
        status, err = self.register("bad-corners", additionalScans=[
            {"scan": cloud_scan(second), "opening": {"corners": corners_json(moved)["corners"][:3]}}])
        self.assertEqual(status, 400, err)
        self.assertIn("additional_scans[0]", err["message"])
        self.assertEqual(self.server.rest("DELETE", "/v1/containers/two-view-box")[0], 200)

    def test_existing_id_is_409_unless_overwrite(self):
        self.assertEqual(self.register("dup-box")[0], 200)
        status, err = self.register("dup-box")
        self.assertEqual(status, 409)
        self.assertEqual(err["code"], 6)
        self.assertIn("dup-box", err["message"])
        self.assertEqual(err["details"], [{
            "@type": "type.googleapis.com/google.rpc.ErrorInfo", "reason": "ALREADY_EXISTS",
            "domain": "soilvol", "metadata": {"field": "container_id"}}])
        self.assertEqual(self.register("dup-box", overwrite=True)[0], 200)

    def test_snake_case_input_and_generated_id(self):
        body = {"scan": cloud_scan(self.empty), "opening": corners_json(box_scene.opening_corners()),
                "max_range_m": 50.0}
        status, container = self.server.rest("POST", "/v1/containers", body)
        self.assertEqual(status, 200, container)
        self.assertRegex(container["containerId"], r"^ctr-[0-9a-f]{12}$")
        self.assertEqual(container["maxRangeM"], 50.0)

    def test_hostile_requests_get_the_right_code(self):
        self.assertEqual(self.register("hostile-box")[0], 200)
        corners = corners_json(box_scene.opening_corners())
        nan_ply = box_scene.encode_ascii_ply([(math.nan, 0, 0)] * 10)
        cases = [
            ("bad base64", "POST", "/v1/containers",
             {"containerId": "h1", "scan": {"cloud": {"data": "@@not base64@@"}}, "opening": corners}, 400),
            ("garbage bytes", "POST", "/v1/containers",
             {"containerId": "h2", "scan": {"cloud": {"data": b64(os.urandom(4096))}}, "opening": corners}, 400),
            ("NaN cloud", "POST", "/v1/containers",
             {"containerId": "h3", "scan": cloud_scan(nan_ply), "opening": corners}, 400),
            ("3 corners", "POST", "/v1/containers",
             {"containerId": "h4", "scan": cloud_scan(self.empty),
              "opening": {"corners": corners["corners"][:3]}}, 400),
            ("both corner kinds", "POST", "/v1/containers",
             {"containerId": "h5", "scan": cloud_scan(self.empty),
              "opening": {"corners": corners["corners"], "pixelCorners": [{"u": 1, "v": 2}] * 4}}, 400),
            ("no scan", "POST", "/v1/containers", {"containerId": "h6", "opening": corners}, 400),
            ("path-like id", "POST", "/v1/containers",
             {"containerId": "../../etc/passwd", "scan": cloud_scan(self.empty), "opening": corners}, 400),
            ("unknown field ignored, no scan", "POST", "/v1/containers",
             {"containerId": "h7", "scan_typo": {}}, 400),
            ("wrong type", "POST", "/v1/containers", {"containerId": 12}, 400),
            ("unknown container", "POST", "/v1/containers/nope:estimate",
             {"scan": cloud_scan(self.empty)}, 404),
            ("stereo scan of a cloud container", "POST", "/v1/containers/hostile-box:estimate",
             {"scan": {"stereo": {"left": b64(b"x"), "right": b64(b"y"), "calibrationId": "nope"}}}, 400),
            ("unknown calibration", "POST", "/v1/containers",
             {"containerId": "h8", "scan": {"stereo": {"left": b64(b"x"), "right": b64(b"y"),
                                                       "calibrationId": "nope"}},
              "opening": {"pixelCorners": [{"u": 1, "v": 2}] * 4}}, 404),
            ("zero cell", "POST", "/v1/containers/hostile-box:estimate",
             {"scan": cloud_scan(self.empty), "gridCellM": 0.0}, 400),
            ("negative density", "POST", "/v1/containers/hostile-box:estimate",
             {"scan": cloud_scan(self.empty), "materialDensityKgM3": -1}, 400),
            ("body id differs from path", "POST", "/v1/containers/hostile-box:estimate",
             {"containerId": "other", "scan": cloud_scan(self.empty)}, 400),
            # Routed first, decoded after (as grpc-gateway does): "a/../b" is no valid id.
            ("encoded slash id", "GET", "/v1/containers/a%2F..%2Fb", None, 400),
            ("dot id", "GET", "/v1/containers/..", None, 400),
            ("unknown calibration get", "GET", "/v1/calibrations/nope", None, 404),
            ("calibration without method", "POST", "/v1/calibrations", {"calibrationId": "c1"}, 400),
            ("parameters with 8 rotation values", "POST", "/v1/calibrations",
             {"calibrationId": "c2", "parameters": {"imageWidth": 640, "imageHeight": 480,
                                                     "left": {"fx": 500, "fy": 500, "cx": 320, "cy": 240},
                                                     "right": {"fx": 500, "fy": 500, "cx": 320, "cy": 240},
                                                     "rotation": [1, 0, 0, 0, 1, 0, 0, 0],
                                                     "translationM": [-0.1, 0, 0]}}, 400),
            ("chessboard with garbage images", "POST", "/v1/calibrations",
             {"calibrationId": "c3", "chessboard": {"pairs": [{"left": b64(b"x"), "right": b64(b"y")}] * 6,
                                                    "innerCorners": {"cols": 9, "rows": 6},
                                                    "squareSizeM": 0.025}}, 400),
            ("unknown route", "GET", "/v1/nothing", None, 404),
            ("wrong verb", "PUT", "/v1/containers", {}, 405),
            ("negative page size", "GET", "/v1/containers?pageSize=-3", None, 400),
            ("foreign page token", "GET", "/v1/containers?page_token=abc", None, 400),
            ("unknown query parameter", "GET", "/v1/containers?nope=1", None, 400),
        ]
        for name, method, path, body, code in cases:
            with self.subTest(name):
                status, err = self.server.rest(method, path, body)
                self.assertEqual(status, code, f"{name}: {err}")
                self.assertIsInstance(err, dict, name)
                self.assertEqual(set(err), {"code", "message", "details"}, name)
                self.assertTrue(err["message"], name)
        for name, raw in [("invalid JSON", b"{not json"), ("truncated JSON", b'{"containerId": "x"'),
                          ("binary body", os.urandom(512))]:
            with self.subTest(name):
                status, err = self.server.rest("POST", "/v1/containers", raw=raw)
                self.assertEqual(status, 400, err)
                self.assertEqual(err["code"], 3)
        self.assertEqual(self.server.rest("GET", "/healthz")[0], 200)
        self.assertTrue(self.server.alive())

    def test_error_bodies_are_google_rpc_status(self):
        status, err = self.server.rest("POST", "/v1/containers/nope:estimate",
                                       {"scan": cloud_scan(self.empty), "gridCellM": 0.0})
        self.assertEqual(status, 404, err)
        status, err = self.server.rest("GET", "/v1/containers/..")
        self.assertEqual(status, 400, err)
        self.assertEqual(err["code"], 3)
        by_type = {d["@type"].rsplit(".", 1)[1]: d for d in err["details"]}
        self.assertEqual(by_type["ErrorInfo"]["reason"], "INVALID_ARGUMENT")
        self.assertEqual(by_type["ErrorInfo"]["domain"], "soilvol")
        self.assertEqual(by_type["ErrorInfo"]["metadata"], {"field": "container_id"})
        self.assertEqual(by_type["BadRequest"]["fieldViolations"][0]["field"], "container_id")
        self.assertTrue(by_type["BadRequest"]["fieldViolations"][0]["description"])

    def test_unknown_json_fields_are_ignored(self):
        status, container = self.register("future-box", overwrite=True,
                                          fieldFromANewerClient={"x": 1}, another_new_field=3)
        self.assertEqual(status, 200, container)
        self.assertEqual(container["containerId"], "future-box")

    def test_patch_updates_what_the_body_sets(self):
        status, created = self.register(
            "patch-box", overwrite=True, displayName="Loader 3",
            material={"name": "gravel", "densityKgM3": 1700},
            loadTargets={"volumeM3": 0.1, "carrybackM3": 0.005})
        self.assertEqual(status, 200, created)
        # grpc-gateway's rule: without updateMask, the mask is the fields the body sets, into
        # nested objects (material.density_kg_m3 keeps material.name).
        status, got = self.server.rest("PATCH", "/v1/containers/patch-box",
                                       {"material": {"densityKgM3": 1900}, "labels": {"k": "v"}})
        self.assertEqual(status, 200, got)
        self.assertEqual((got["material"]["name"], got["material"]["densityKgM3"]),
                         ("gravel", 1900))
        self.assertEqual(got["labels"], {"k": "v"})
        self.assertEqual(got["displayName"], "Loader 3")
        self.assertEqual(got["loadTargets"], created["loadTargets"])
        # An explicit mask in the query: a masked field the body leaves out is cleared.
        status, got = self.server.rest("PATCH", "/v1/containers/patch-box?updateMask=displayName,labels",
                                       {"displayName": "L3"})
        self.assertEqual(status, 200, got)
        self.assertEqual(got["displayName"], "L3")
        self.assertEqual(got.get("labels", {}), {})
        status, got = self.server.rest("PATCH", "/v1/containers/patch-box",
                                       {"etag": "0123456789abcdef", "displayName": "x"})
        self.assertEqual(status, 409, got)
        status, got = self.server.rest("PATCH", "/v1/containers/patch-box?update_mask=depthM", {})
        self.assertEqual(status, 400, got)
        self.assertIn("update_mask: names nothing", got["message"])
        # What GET returned, sent back whole with one change: output-only fields are ignored.
        status, whole = self.server.rest("GET", "/v1/containers/patch-box")
        whole["displayName"] = "L4"
        status, got = self.server.rest("PATCH", "/v1/containers/patch-box", whole)
        self.assertEqual(status, 200, got)
        self.assertEqual(got["displayName"], "L4")
        self.assertNotEqual(got["etag"], whole["etag"])
        status, got = self.server.rest("PATCH", "/v1/containers/patch-box",
                                       {"loadTargets": {"payloadKg": 1e9}})
        self.assertEqual(status, 200, got)  # payload with the stored density
        status, got = self.server.rest("PATCH", "/v1/containers/patch-box", {"material": None})
        self.assertEqual(status, 400, got)  # null clears: a payload target without a density
        self.assertIn("container.load_targets.payload_kg", got["message"])
        status, est = self.estimate("patch-box", 0.1)
        self.assertEqual(status, 200, est)
        self.assertEqual(est["load"]["status"], "LOAD_STATUS_UNDERLOADED")
        self.assertAlmostEqual(est["massKg"], 1900 * est["volumeM3"], delta=1e-6)

    def test_lists_page_with_opaque_tokens(self):
        for i in range(5):
            status, body = self.server.rest("POST", "/v1/calibrations", {
                "calibrationId": f"rest-page-{i}", "overwrite": True, "parameters": {
                    "imageWidth": 640, "imageHeight": 480,
                    "left": {"fx": 500, "fy": 500, "cx": 320, "cy": 240},
                    "right": {"fx": 500, "fy": 500, "cx": 320, "cy": 240},
                    "rotation": [1, 0, 0, 0, 1, 0, 0, 0, 1], "translationM": [-0.1, 0, 0]}})
            self.assertEqual(status, 200, body)
        seen, token, pages = [], "", 0
        while True:
            status, page = self.server.rest("GET", f"/v1/calibrations?pageSize=2&pageToken={token}")
            self.assertEqual(status, 200, page)
            self.assertLessEqual(len(page["calibrations"]), 2)
            seen += [c["calibrationId"] for c in page["calibrations"]]
            pages += 1
            token = page["nextPageToken"]
            if not token:
                break
        self.assertEqual(seen, sorted(seen))
        self.assertEqual(len(seen), len(set(seen)))
        self.assertLessEqual({f"rest-page-{i}" for i in range(5)}, set(seen))
        self.assertGreaterEqual(pages, 3)

    def test_request_ids_are_echoed_and_info_is_served(self):
        status, info, headers = self.server.rest_with_headers(
            "GET", "/v1/info", headers={"X-Request-Id": "dash-42",
                                        "traceparent": "00-4bf92f3577b34da6a3ce929d0e0e4736-"
                                                       "00f067aa0ba902b7-01"})
        self.assertEqual(status, 200, info)
        self.assertEqual(headers["X-Request-Id"], "dash-42")
        self.assertRegex(info["version"], r"^\d+\.\d+\.\d+$")
        self.assertEqual(info["api"], "soilvol.v1.SoilVolume")
        self.assertIn("opencv", info["libraries"])
        _, _, headers = self.server.rest_with_headers("GET", "/v1/containers/nope")
        self.assertRegex(headers["X-Request-Id"], r"^[0-9a-f]{32}$")
        _, _, headers = self.server.rest_with_headers("GET", "/v1/containers/nope",
                                                      headers={"X-Request-Id": "bad id\u00e9"})
        self.assertRegex(headers["X-Request-Id"], r"^[0-9a-f]{32}$")

    def test_deadline_header(self):
        self.assertEqual(self.register("deadline-box", overwrite=True)[0], 200)
        scan = box_scene.encode_ply(box_scene.box_scan(0.2, seed=3))
        status, err = self.server.rest("POST", "/v1/containers/deadline-box:estimate",
                                       {"scan": cloud_scan(scan)}, headers={"Grpc-Timeout": "1n"})
        self.assertEqual(status, 504, err)
        self.assertEqual(err["code"], 4)
        status, err = self.server.rest("GET", "/v1/containers", headers={"Grpc-Timeout": "soon"})
        self.assertEqual(status, 400, err)

    def test_health_ready_metrics(self):
        self.assertEqual(self.server.rest("GET", "/healthz"), (200, {"status": "SERVING"}))
        self.assertEqual(self.server.rest("GET", "/readyz"), (200, {"status": "SERVING"}))
        self.server.rest("GET", "/v1/containers")
        status, text = self.server.rest("GET", "/metrics")
        self.assertEqual(status, 200)
        for name in ("soilvol_requests_total", "soilvol_request_duration_seconds_bucket",
                     "soilvol_in_flight", "soilvol_queue_depth", "soilvol_workers"):
            self.assertIn(name, text)
        self.assertRegex(text, r'soilvol_requests_total\{code="OK",method="ListContainers",'
                               r'transport="http"\} [1-9]')

    @unittest.skipUnless(os.path.exists(f"{OPENCV_DATA}/left01.jpg"), "opencv-doc not installed")
    def test_real_chessboard_calibration(self):
        pairs = []
        for left in sorted(glob.glob(f"{OPENCV_DATA}/left[0-9][0-9].jpg")):
            right = left.replace("left", "right")
            if os.path.exists(right):
                pairs.append({"left": b64(read_bytes(left)), "right": b64(read_bytes(right))})
        body = {"calibrationId": "opencv-doc", "overwrite": True,
                "chessboard": {"pairs": pairs, "innerCorners": {"cols": 9, "rows": 6},
                               "squareSizeM": 0.025}}
        status, cal = self.server.rest("POST", "/v1/calibrations", body)
        self.assertEqual(status, 200, cal)
        self.assertEqual(cal["pairsUsed"], 13)
        self.assertLess(cal["rmsReprojectionErrorPx"], 0.3)
        # OpenCV's stereo_calib sample finds |T| = 3.343 squares on these pairs.
        self.assertAlmostEqual(cal["baselineM"] / 0.025, 3.34, delta=0.05)
        self.assertEqual((cal["imageWidth"], cal["imageHeight"]), (640, 480))
        status, again = self.server.rest("GET", "/v1/calibrations/opencv-doc")
        self.assertEqual(status, 200)
        self.assertEqual(again["baselineM"], cal["baselineM"])
        # The parameters it returns calibrate again to the same rig.
        status, copy = self.server.rest("POST", "/v1/calibrations",
                                        {"calibrationId": "copy", "parameters": cal["parameters"],
                                         "overwrite": True})
        self.assertEqual(status, 200, copy)
        self.assertAlmostEqual(copy["baselineM"], cal["baselineM"], places=9)
        self.assertEqual(copy["source"], "CALIBRATION_SOURCE_PARAMETERS")

    @needs_own_server
    def test_cors(self):
        with Server(args=["--workers", "1", "--cors-origin", "https://dash.example"]) as server:
            status, _, headers = server.rest_with_headers(
                "OPTIONS", "/v1/containers",
                headers={"Origin": "https://dash.example", "Access-Control-Request-Method": "GET",
                         "Access-Control-Request-Headers": "authorization, x-request-id"})
            self.assertEqual(status, 204)
            allowed = {h.strip().lower() for h in headers["Access-Control-Allow-Headers"].split(",")}
            self.assertLessEqual({"authorization", "x-request-id", "traceparent"}, allowed)
            exposed = {h.strip().lower() for h in headers["Access-Control-Expose-Headers"].split(",")}
            self.assertLessEqual({"retry-after", "x-request-id"}, exposed)
            status, _, headers = server.rest_with_headers(
                "GET", "/v1/info", headers={"Origin": "https://dash.example"})
            self.assertEqual(status, 200)
            self.assertEqual(headers["Access-Control-Allow-Origin"], "https://dash.example")
            status, _ = server.rest("OPTIONS", "/v1/containers", headers={"Origin": "https://evil.example"})
            self.assertEqual(status, 403)

    @needs_own_server
    def test_oversize_body_is_413_and_server_keeps_serving(self):
        with Server(args=["--workers", "1", "--max-message-mb", "1"]) as server:
            big = {"containerId": "big", "scan": cloud_scan(os.urandom(3 << 20))}
            status, err = server.rest("POST", "/v1/containers", big)
            self.assertEqual(status, 413, err)
            self.assertEqual(err["code"], 8)
            self.assertEqual(server.rest("GET", "/v1/containers")[0], 200)


if __name__ == "__main__":
    unittest.main(verbosity=2)
