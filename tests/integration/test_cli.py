"""The soilvol CLI (the C++ gRPC client) against a real server: demo, resources, errors."""
import json
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
import depth_scene  # noqa: E402
import mesh_scene  # noqa: E402
from harness import CLI_BIN, shared_server  # noqa: E402

# The demo's own simulator (paper bucket, 4 cm time-of-flight noise): its worst fill reads up to
# 3.3% of struck low (issue 11's target is 1.5%, not met on this box yet); stereo (rendered
# 640x480 pairs at 3 m) below 6%.
CLOUD_LIMIT_PCT = 4.0
# Stereo reads the full bucket 5% low: its registered capacity is 6% low (issue 11, item 6).
STEREO_LIMIT_PCT = 6.0
# A 640x480 ToF camera's depth images (flying pixels, multipath): issue 29's max is 2% of struck
# (measured: 0.92% at worst).
DEPTH_LIMIT_PCT = 2.0


class Cli(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if not os.path.exists(CLI_BIN):
            raise unittest.SkipTest(f"no CLI at {CLI_BIN}")
        cls.server = shared_server()

    @classmethod
    def tearDownClass(cls):
        cls.server.close()

    def run_cli(self, *args, check=True):
        proc = subprocess.run([CLI_BIN, "--server", self.server.grpc_target, *args],
                              capture_output=True, text=True, timeout=300)
        if check:
            self.assertEqual(proc.returncode, 0, proc.stderr)
        return proc

    def test_demo_cloud_stereo_and_depth_meet_their_accuracy(self):
        for extra, limit in (([], CLOUD_LIMIT_PCT), (["--stereo"], STEREO_LIMIT_PCT),
                             (["--depth"], DEPTH_LIMIT_PCT)):
            with self.subTest(extra=extra):
                rows = json.loads(self.run_cli("--json", "demo", *extra).stdout)
                self.assertEqual(len(rows), 5)
                for row in rows:
                    self.assertLess(abs(row["errorPctStruck"]), limit, row)
        listed = json.loads(self.run_cli("--json", "containers", "list").stdout)
        left = [c["containerId"] for c in listed.get("containers", [])
                if c["containerId"].startswith("demo-")]
        self.assertEqual(left, [], "the demo deletes what it made")

    def test_a_site_frame_cloud_with_its_sensor_pose(self):
        # test_sensor_pose.py's gantry: the camera 5 m up, tilted 30 deg about x.
        tilt = np.radians(30.0)
        rotation = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)],
                             [0, np.sin(tilt), np.cos(tilt)]])
        origin = np.array([3.0, -2.0, 5.0])
        pose = ",".join(f"{v:.17g}" for v in (*origin, np.cos(tilt / 2), np.sin(tilt / 2), 0, 0))
        with tempfile.TemporaryDirectory() as tmp:
            paths = {}
            for name, fill, seed in (("empty", 0.0, 21), ("full", 0.2, 22)):
                z = depth_scene.millimetres(depth_scene.render(fill, 0.002, seed=seed))
                points = depth_scene.back_project_as_core(z)
                site = points.astype(np.float64) @ rotation.T + origin
                # The image's halves, as two sensors' parts of one scan (same pose).
                halves = [z.copy(), z.copy()]
                halves[0][:, depth_scene.WIDTH // 2:] = 0
                halves[1][:, :depth_scene.WIDTH // 2] = 0
                parts = [depth_scene.back_project_as_core(h).astype(np.float64) @ rotation.T
                         + origin for h in halves]
                for frame, cloud in (("sensor", points), ("site", site), ("left", parts[0]),
                                     ("right", parts[1])):
                    paths[name, frame] = os.path.join(tmp, f"{name}-{frame}.ply")
                    with open(paths[name, frame], "wb") as f:
                        f.write(box_scene.encode_ply(cloud))
            corners = ";".join(f"{x},{y},{z}" for x, y, z in depth_scene.opening_corners())
            self.run_cli("register", "--id", "cli-gantry", "--cloud", paths["empty", "site"],
                         "--sensor-pose", pose, "--corners", corners)
            in_site = json.loads(self.run_cli("--json", "estimate", "--id", "cli-gantry",
                                              "--cloud", paths["full", "site"],
                                              "--sensor-pose", pose).stdout)
            in_sensor = json.loads(self.run_cli("--json", "estimate", "--id", "cli-gantry",
                                                "--cloud", paths["full", "sensor"]).stdout)
            self.assertLess(abs(in_site["volumeM3"] - in_sensor["volumeM3"]),
                            0.0005 * box_scene.STRUCK_M3)
            # Two sensors' parts of one scan (Scan.additional_sensors), each with its pose.
            in_parts = json.loads(self.run_cli(
                "--json", "estimate", "--id", "cli-gantry", "--cloud", paths["full", "left"],
                "--sensor-pose", pose, "--also-cloud", paths["full", "right"],
                "--also-sensor-pose", pose).stdout)
            self.assertLess(abs(in_parts["volumeM3"] - in_sensor["volumeM3"]),
                            0.005 * box_scene.STRUCK_M3)
            short = self.run_cli("estimate", "--id", "cli-gantry", "--cloud",
                                 paths["full", "left"], "--also-cloud", paths["full", "right"],
                                 "--also-sensor-pose", "1,2,3", check=False)
            self.assertEqual(short.returncode, 2, short.stderr)  # a usage error
            self.assertIn("--also-sensor-pose: give 7 numbers", short.stderr)
            self.run_cli("containers", "delete", "cli-gantry")

    def test_register_and_estimate_from_depth_images(self):
        with tempfile.TemporaryDirectory() as tmp:
            paths = {}
            for name, fill, seed in (("empty", 0.0, 11), ("full", 0.25, 12)):
                z = depth_scene.millimetres(depth_scene.render(fill, 0.002, seed=seed))
                paths[name] = os.path.join(tmp, f"{name}.png")
                with open(paths[name], "wb") as f:
                    f.write(depth_scene.encode_png(z))
            k = depth_scene.intrinsics()
            camera = ["--intrinsics", f"{k['fx']},{k['fy']},{k['cx']},{k['cy']}"]
            corners = ";".join(f"{x},{y},{z}" for x, y, z in depth_scene.opening_corners())
            out = json.loads(self.run_cli("--json", "register", "--id", "cli-depth", "--depth",
                                          paths["empty"], *camera, "--corners", corners).stdout)
            self.assertEqual(out["registeredFrom"], "SCAN_KIND_DEPTH")
            est = json.loads(self.run_cli("--json", "estimate", "--id", "cli-depth", "--depth",
                                          paths["full"], *camera, "--depth-noise", "0.004").stdout)
            truth = box_scene.INNER_L * box_scene.INNER_W * 0.25
            self.assertLess(abs(est["volumeM3"] - truth), 0.04 * box_scene.STRUCK_M3)
            self.assertEqual(int(est["depthPixels"]["pixels"]),
                             depth_scene.WIDTH * depth_scene.HEIGHT)
            shown = self.run_cli("estimate", "--id", "cli-depth", "--depth", paths["full"],
                                 *camera).stdout
            self.assertIn("back-projected", shown)
            bad = self.run_cli("estimate", "--id", "cli-depth", "--depth", paths["full"],
                               "--intrinsics", "0,250,160,120", check=False)
            self.assertEqual(bad.returncode, 1, bad.stderr)
            self.assertIn("scan.depth.camera.fx/fy", bad.stderr)
            self.run_cli("containers", "delete", "cli-depth")

    def test_register_get_estimate_delete_from_files(self):
        with tempfile.TemporaryDirectory() as tmp:
            empty = os.path.join(tmp, "empty.ply")
            full = os.path.join(tmp, "scan.ply")
            with open(empty, "wb") as f:
                f.write(box_scene.encode_ply(box_scene.box_scan(0.0, seed=1)))
            with open(full, "wb") as f:
                f.write(box_scene.encode_ply(box_scene.box_scan(0.25, seed=2)))
            corners = ";".join(f"{x},{y},{z}" for x, y, z in box_scene.opening_corners())
            out = json.loads(self.run_cli("--json", "register", "--id", "cli-box", "--cloud",
                                          empty, "--corners", corners).stdout)
            self.assertEqual(out["containerId"], "cli-box")
            est = json.loads(self.run_cli("--json", "estimate", "--id", "cli-box", "--cloud",
                                          full, "--density-kg-m3", "1500").stdout)
            truth = box_scene.INNER_L * box_scene.INNER_W * 0.25
            self.assertLess(abs(est["volumeM3"] - truth), 0.04 * box_scene.STRUCK_M3)
            self.assertAlmostEqual(est["massKg"], 1500 * est["volumeM3"], places=6)
            table = self.run_cli("containers", "get", "cli-box").stdout
            self.assertIn("cli-box", table)
            # Settings change without a rescan; only the flags given are in the mask.
            out = json.loads(self.run_cli(
                "--json", "containers", "update", "cli-box", "--display-name", "Truck 9",
                "--label", "site=north", "--material", "sand", "--density", "1600",
                "--target-volume", f"{2 * truth}").stdout)
            self.assertEqual((out["displayName"], out["labels"], out["material"]["name"]),
                             ("Truck 9", {"site": "north"}, "sand"))
            out = json.loads(self.run_cli("--json", "containers", "update", "cli-box",
                                          "--density", "1700").stdout)
            self.assertEqual((out["displayName"], out["material"]["name"],
                              out["material"]["densityKgM3"]), ("Truck 9", "sand", 1700))
            shown = self.run_cli("estimate", "--id", "cli-box", "--cloud", full).stdout
            self.assertIn("underloaded", shown)
            # Records: listed, read back, and watched as new ones arrive.
            listed = json.loads(self.run_cli("--json", "estimates", "list", "--container",
                                             "cli-box").stdout)
            ids = [e["estimateId"] for e in listed["estimates"]]
            self.assertEqual(ids[-1], est["estimateId"])
            got = json.loads(self.run_cli("--json", "estimates", "get", "cli-box",
                                          est["estimateId"]).stdout)
            self.assertEqual(got["result"]["volumeM3"], est["volumeM3"])
            self.assertIn("underloaded", self.run_cli("estimates", "list").stdout)
            watcher = subprocess.Popen(
                [CLI_BIN, "--server", self.server.grpc_target, "--json", "estimates", "watch",
                 "--container", "cli-box", "--after", ids[-1], "--count", "2"],
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            newest = json.loads(self.run_cli("--json", "estimate", "--id", "cli-box", "--cloud",
                                             full).stdout)
            out, err = watcher.communicate(timeout=60)
            self.assertEqual(watcher.returncode, 0, err)
            seen = [json.loads(line)["estimateId"] for line in out.splitlines()]
            # After the oldest: the one recorded since (caught up), then the live one.
            self.assertEqual(ids, [ids[0], est["estimateId"]])
            self.assertEqual(seen, [ids[0], newest["estimateId"]])
            stale = self.run_cli("containers", "update", "cli-box", "--etag", "0" * 16,
                                 "--display-name", "x", check=False)
            self.assertEqual(stale.returncode, 1)
            self.assertIn("ABORTED", stale.stderr)
            # Every registration's records with --registration -; a purge removes them all.
            every = json.loads(self.run_cli("--json", "estimates", "list", "--container",
                                            "cli-box", "--registration", "-").stdout)
            self.assertEqual(len(every["estimates"]), 3)
            self.run_cli("containers", "delete", "cli-box", "--purge-records")
            gone = self.run_cli("estimate", "--id", "cli-box", "--cloud", full, check=False)
            self.assertEqual(gone.returncode, 1)
            self.assertIn("NOT_FOUND", gone.stderr)
            left = json.loads(self.run_cli("--json", "estimates", "list", "--container",
                                           "cli-box", "--registration", "-").stdout)
            self.assertEqual(left.get("estimates", []), [])

    def test_register_from_a_mesh_and_show_the_capacitys_uncertainty(self):
        with tempfile.TemporaryDirectory() as tmp:
            stl = os.path.join(tmp, "box.stl")
            empty = os.path.join(tmp, "empty.ply")
            full = os.path.join(tmp, "fill.ply")
            with open(stl, "wb") as f:
                f.write(mesh_scene.mesh_stl())
            with open(empty, "wb") as f:
                f.write(box_scene.encode_ply(mesh_scene.scan(0.0, seed=1)))
            with open(full, "wb") as f:
                f.write(box_scene.encode_ply(mesh_scene.scan(0.3, seed=2)))

            def tuples(points):
                return ";".join(",".join(f"{v:.6f}" for v in p) for p in points)

            position, quaternion = mesh_scene.mesh_pose()
            pose = f"{tuples([position])};{','.join(f'{q:.9f}' for q in quaternion)}"
            mesh_corners = tuples(mesh_scene.mesh_corners())
            # The mesh alone, placed before the sensor.
            out = self.run_cli("register", "--id", "cli-mesh", "--overwrite", "--mesh", stl,
                               "--mesh-corners", mesh_corners, "--container-pose", pose,
                               "--range-noise", str(mesh_scene.RANGE_NOISE_M)).stdout
            self.assertIn("registered from        mesh\n", out)
            self.assertIn("struck capacity [m^3]  0.7680", out)
            self.assertIn("struck 1-sigma [L]     0.0", out)
            self.assertNotIn("warning:", out)
            est = json.loads(self.run_cli("--json", "estimate", "--id", "cli-mesh", "--cloud",
                                          full).stdout)
            self.assertLess(abs(est["volumeM3"] - mesh_scene.truth_m3(0.3)),
                            0.01 * mesh_scene.STRUCK_M3)
            # One empty scan alone warns; with the mesh beside it, the inside is known.
            out = self.run_cli("register", "--id", "cli-scan", "--overwrite", "--cloud", empty,
                               "--corners", tuples(mesh_scene.scan_opening_corners())).stdout
            self.assertRegex(out, r"struck 1-sigma \[L\] +1\d\.\d")
            self.assertIn("unseen sides           corners ", out)
            self.assertIn("\nwarning: the struck capacity's 1-sigma is ", out)
            out = self.run_cli("register", "--id", "cli-scan-mesh", "--overwrite", "--cloud",
                               empty, "--corners", tuples(mesh_scene.scan_opening_corners()),
                               "--mesh", stl, "--mesh-corners", mesh_corners).stdout
            self.assertIn("registered from        cloud + mesh\n", out)
            self.assertNotIn("warning:", out)
            shown = self.run_cli("containers", "get", "cli-scan").stdout
            self.assertIn("\nwarning: the struck capacity's 1-sigma is ", shown)
            listed = self.run_cli("containers", "list").stdout
            self.assertIn("1-sigma [L]", listed)
            self.assertIn("\nwarning: cli-scan: the struck capacity's 1-sigma is ", listed)
            self.assertNotIn("warning: cli-mesh", listed)
            for cid in ("cli-mesh", "cli-scan", "cli-scan-mesh"):
                self.run_cli("containers", "delete", cid)

    def test_version_matches_the_server(self):
        out = subprocess.run([CLI_BIN, "--version"], capture_output=True, text=True, check=True,
                             timeout=30).stdout
        info = self.server.rest("GET", "/v1/info")[1]
        self.assertTrue(out.startswith(f"soilvol {info['version']} (revision "), out)

    def test_errors_exit_non_zero_with_the_server_message(self):
        bad = self.run_cli("register", "--id", "../x", "--cloud", "/dev/null", "--corners",
                           "0,0,0;1,0,0;1,1,0;0,1,0", check=False)
        self.assertNotEqual(bad.returncode, 0)
        missing = self.run_cli("estimate", "--id", "x", "--cloud", "/no/such.ply", check=False)
        self.assertEqual(missing.returncode, 2)
        self.assertIn("/no/such.ply", missing.stderr)
        health = self.run_cli("health")
        self.assertIn("SERVING", health.stdout)


if __name__ == "__main__":
    unittest.main(verbosity=2)
