"""Several sensors in one scan (Scan.additional_sensors): the box of box_scene.py seen by the
depth camera of depth_scene.py, whose image is split in two halves handed over as two sensors'
parts, each with the camera's pose in a site frame (5 m up a gantry, tilted 30 deg): the left
half as a site-frame cloud with CloudScan.sensor_pose, the right half as a depth image with
DepthScan.sensor_pose. Registration and estimates from the two parts answer as the whole image
does, over REST JSON and gRPC; what the parts saw is counted once; hostile parts are refused
naming the field. (Two sensors at different places: the bench's multi-sensor table.)"""
import json
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
import depth_scene  # noqa: E402
# Its gantry pose, its checks that curl is there, and its gRPC modules.
import test_sensor_pose as site  # noqa: E402
from harness import SharedServerCase, b64, corners_json, post_json  # noqa: E402

grpc, pb, pb_grpc = site.grpc, site.pb, site.pb_grpc

# The halves are filtered apart (outliers per cloud, flying pixels on the depth half only): a
# few returns at the seam and the rim differ from the whole image's.
SAME_OF_STRUCK = 0.005
TRUTH_OF_STRUCK = 0.04  # the whole image's own tolerance (test_sensor_pose.py)
HALF = depth_scene.WIDTH // 2


def halves(fill_m, seed):
    """The whole image's cloud (camera frame), the left half's cloud and the right half's
    16-bit PNG (the left half's pixels read as no return)."""
    z_mm = depth_scene.millimetres(depth_scene.render(fill_m, 0.002, seed=seed))
    left = z_mm.copy()
    left[:, HALF:] = 0
    right = z_mm.copy()
    right[:, :HALF] = 0
    return (depth_scene.back_project_as_core(z_mm), depth_scene.back_project_as_core(left),
            depth_scene.encode_png(right))


def two_part_scan(left_points, right_png):
    return {"cloud": {"data": b64(box_scene.encode_ply(site.to_site(left_points))),
                      "sensorPose": site.pose_json()},
            "additionalSensors": [{"depth": {"depth": b64(right_png),
                                             "camera": depth_scene.intrinsics(),
                                             "sensorPose": site.pose_json()}}]}


class SeveralSensors(SharedServerCase):
    grpc_modules = (grpc, pb, pb_grpc)
    scratch_prefix = "soilvol-sensors-"

    @classmethod
    def setUpServer(cls):
        cls.opening = corners_json(depth_scene.opening_corners())
        whole, left, right = halves(0.0, seed=21)
        status, cls.whole = cls.register("rig-whole", {"cloud": {"data": b64(
            box_scene.encode_ply(whole))}})
        assert status == 200, cls.whole
        status, cls.parts = cls.register("rig-parts", two_part_scan(left, right))
        assert status == 200, cls.parts

    @classmethod
    def register(cls, container_id, scan):
        return post_json(cls.server, cls.dir, "/v1/containers",
                         {"containerId": container_id, "scan": scan, "opening": cls.opening,
                          "overwrite": True})

    def estimate(self, container_id, scan):
        return post_json(self.server, self.dir, f"/v1/containers/{container_id}:estimate",
                         {"skipRecord": True, "scan": scan})

    def assert_same(self, a, b, what):
        share = abs(a - b) / box_scene.STRUCK_M3
        print(f"{what}: {share:.4%} of struck apart", file=sys.stderr)
        self.assertLess(share, SAME_OF_STRUCK, (what, a, b))

    def test_registration_from_two_parts_matches_the_whole_image(self):
        self.assert_same(self.parts["struckCapacityM3"], self.whole["struckCapacityM3"],
                         "struck capacity, two parts vs the whole image")
        self.assertGreater(self.parts["observedShare"], 0.95, self.parts)

    def test_two_parts_answer_as_the_whole_image_over_rest(self):
        whole, left, right = halves(0.25, seed=22)
        status, reference = self.estimate("rig-whole", {"cloud": {"data": b64(
            box_scene.encode_ply(whole))}})
        self.assertEqual(status, 200, reference)
        status, parts = self.estimate("rig-parts", two_part_scan(left, right))
        self.assertEqual(status, 200, parts)
        self.assert_same(parts["volumeM3"], reference["volumeM3"], "estimate over REST")
        truth = box_scene.INNER_L * box_scene.INNER_W * 0.25
        self.assertLess(abs(parts["volumeM3"] - truth), TRUTH_OF_STRUCK * box_scene.STRUCK_M3)
        # What either half saw counts: together they cover what the whole image covers.
        self.assertGreater(parts["coverage"]["scanObservedShare"],
                           reference["coverage"]["scanObservedShare"] - 0.03, parts)
        # The depth half's pixels are counted, the cloud half's are not pixels.
        self.assertEqual(int(parts["depthPixels"]["pixels"]),
                         depth_scene.WIDTH * depth_scene.HEIGHT, parts["depthPixels"])
        # One half alone saw half the opening: the two parts' coverage is the union.
        status, alone = self.estimate("rig-parts", {
            "cloud": {"data": b64(box_scene.encode_ply(site.to_site(left))), "sensorPose": site.pose_json()}})
        if status == 200:
            self.assertLess(alone["coverage"]["scanObservedShare"],
                            parts["coverage"]["scanObservedShare"] - 0.2, (alone, parts))

    def test_grpc_carries_the_additional_sensors(self):
        whole, left, right = halves(0.15, seed=23)
        w, x, y, z = site.SITE_Q
        pose = pb.Pose(position_m=pb.Point3(x=site.SITE_T[0], y=site.SITE_T[1], z=site.SITE_T[2]),
                       orientation=pb.Quaternion(w=w, x=x, y=y, z=z))
        scan = pb.Scan(
            cloud=pb.CloudScan(data=box_scene.encode_ply(site.to_site(left)), sensor_pose=pose),
            additional_sensors=[pb.SensorScan(depth=pb.DepthScan(
                depth=right, camera=pb.DepthCamera(**depth_scene.intrinsics()),
                sensor_pose=pose))])
        over_grpc = self.stub.EstimateVolume(
            pb.EstimateVolumeRequest(container_id="rig-parts", skip_record=True, scan=scan),
            timeout=60)
        status, over_json = self.estimate("rig-parts", two_part_scan(left, right))
        self.assertEqual(status, 200, over_json)
        self.assertAlmostEqual(over_grpc.volume_m3, over_json["volumeM3"], places=9)

    def test_hostile_parts_are_refused_naming_the_field(self):
        _, left, right = halves(0.2, seed=24)
        scan = two_part_scan(left, right)
        cases = []
        empty_part = json.loads(json.dumps(scan))
        empty_part["additionalSensors"] = [{}]
        cases.append((empty_part, "scan.additional_sensors[0]: is empty"))
        too_many = json.loads(json.dumps(scan))
        too_many["additionalSensors"] = too_many["additionalSensors"] * 8
        cases.append((too_many, "scan.additional_sensors: at most 7"))
        bad_pose = json.loads(json.dumps(scan))
        bad_pose["additionalSensors"][0]["depth"]["sensorPose"]["orientation"]["w"] = 3.0
        cases.append((bad_pose, "scan.additional_sensors[0].depth.sensor_pose.orientation"))
        bad_cloud = json.loads(json.dumps(scan))
        bad_cloud["additionalSensors"] = [{"cloud": {"data": b64(b"ply\nformat nonsense\n")}}]
        cases.append((bad_cloud, "scan.additional_sensors[0].cloud.data"))
        for body, field in cases:
            status, error = self.estimate("rig-parts", body)
            self.assertEqual(status, 400, (field, error))
            self.assertIn(field, error["message"])
        with self.assertRaises(grpc.RpcError) as raised:
            self.stub.EstimateVolume(pb.EstimateVolumeRequest(
                container_id="rig-parts", skip_record=True,
                scan=pb.Scan(cloud=pb.CloudScan(data=box_scene.encode_ply(left)),
                             additional_sensors=[pb.SensorScan()])), timeout=60)
        self.assertEqual(raised.exception.code(), grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("scan.additional_sensors[0]", raised.exception.details())


if __name__ == "__main__":
    unittest.main()
