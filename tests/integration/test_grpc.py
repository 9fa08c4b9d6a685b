"""The gRPC contract, end to end against a real server process, with python3-grpcio and stubs
generated from proto/soilvol/v1/soilvol.proto. The health service is called with hand-encoded
messages (stubs for grpc.health.v1 would clash with the python package named grpc)."""
import math
import os
import signal
import struct
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import (TIME_SCALE, Server, load_grpc, needs_own_server, server_metric,  # noqa: E402
                     shared_server, wait_until)  # noqa: E402

grpc, pb, pb_grpc = load_grpc()
from google.rpc import error_details_pb2, status_pb2  # noqa: E402  (generated beside the stubs)
from google.protobuf import field_mask_pb2  # noqa: E402

# As in test_rest.py: the box is measured to within this share of its struck capacity.
TOLERANCE_OF_STRUCK = 0.04
CODE = grpc.StatusCode


def cloud(ply):
    return pb.Scan(cloud=pb.CloudScan(data=ply))


def box_opening(corners=None):
    corners = box_scene.opening_corners() if corners is None else corners
    return pb.Opening(corners=[pb.Point3(x=x, y=y, z=z) for x, y, z in corners])


def filled_box(fill, seed=7, step=0.012):
    """A scan of the box with `fill` metres of soil, moved and turned against the empty one."""
    return box_scene.encode_ply(box_scene.box_scan(fill, seed=seed, step=step,
                                                   shift=(0.03, -0.02, 0.01), yaw_deg=2.0))


def unpack_details(status):
    """{type name: message} of a google.rpc.Status's details."""
    out = {}
    for any_ in status.details:
        name = any_.type_url.rsplit(".", 1)[1]
        message = getattr(error_details_pb2, name)()
        any_.Unpack(message)
        out[name] = message
    return out


def rpc_status(err):
    """The google.rpc.Status of a failed call, from its grpc-status-details-bin trailer."""
    for key, value in err.trailing_metadata() or ():
        if key == "grpc-status-details-bin":
            return status_pb2.Status.FromString(value)
    raise AssertionError(f"no grpc-status-details-bin in {err.trailing_metadata()}")


def yaw_pose(x, y, z, yaw_deg):
    half = math.radians(yaw_deg) / 2
    return pb.Pose(position_m=pb.Point3(x=x, y=y, z=z),
                   orientation=pb.Quaternion(w=math.cos(half), z=math.sin(half)))


PARAMS = dict(image_width=640, image_height=480,
              left=dict(fx=500, fy=500, cx=320, cy=240), right=dict(fx=500, fy=500, cx=320, cy=240),
              rotation=[1, 0, 0, 0, 1, 0, 0, 0, 1], translation_m=[-0.1, 0, 0])


def truth_m3(fill):
    return box_scene.INNER_L * box_scene.INNER_W * fill


# grpc.health.v1 by hand: HealthCheckRequest {string service = 1}, HealthCheckResponse
# {ServingStatus status = 1} with SERVING = 1, NOT_SERVING = 2.
SERVING, NOT_SERVING = 1, 2


def encode_health_request(service):
    data = service.encode()
    assert len(data) < 128, "one-byte length only"
    return b"\x0a" + bytes([len(data)]) + data if data else b""


def decode_health_response(data):
    """The status field of a HealthCheckResponse (0 when absent, as proto3 says)."""
    status, i = 0, 0
    while i < len(data):
        key = data[i]
        i += 1
        if key & 7 != 0:
            raise ValueError(f"unexpected wire type in {data!r}")
        value, shift = 0, 0
        while True:
            byte = data[i]
            i += 1
            value |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                break
        if key >> 3 == 1:
            status = value
    return status


def health_methods(channel):
    check = channel.unary_unary("/grpc.health.v1.Health/Check",
                                request_serializer=encode_health_request,
                                response_deserializer=decode_health_response)
    watch = channel.unary_stream("/grpc.health.v1.Health/Watch",
                                 request_serializer=encode_health_request,
                                 response_deserializer=decode_health_response)
    return check, watch


class GrpcFlow(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = shared_server()
        cls.channel = cls.server.channel(grpc)
        cls.stub = pb_grpc.SoilVolumeStub(cls.channel)
        cls.empty = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        cls.server.close()

    def register(self, cid, **extra):
        request = pb.RegisterContainerRequest(container_id=cid, scan=cloud(self.empty),
                                              opening=box_opening(), **extra)
        return self.stub.RegisterContainer(request, timeout=60)

    def assert_code(self, call, code, *fragments):
        """Runs call(); it must fail with `code` and a message holding every fragment."""
        with self.assertRaises(grpc.RpcError) as ctx:
            call()
        err = ctx.exception
        self.assertEqual(err.code(), code, err.details())
        for fragment in fragments:
            self.assertIn(fragment, err.details())
        return err

    def test_calibration_lifecycle(self):
        params = pb.StereoParameters(
            image_width=640, image_height=480,
            left=pb.CameraIntrinsics(fx=500, fy=500, cx=320, cy=240),
            right=pb.CameraIntrinsics(fx=500, fy=500, cx=320, cy=240),
            rotation=[1, 0, 0, 0, 1, 0, 0, 0, 1], translation_m=[-0.1, 0, 0])
        cal = self.stub.Calibrate(pb.CalibrateRequest(calibration_id="rig", parameters=params),
                                  timeout=30)
        self.assertEqual(cal.calibration_id, "rig")
        self.assertEqual(cal.source, pb.CALIBRATION_SOURCE_PARAMETERS)
        self.assertEqual((cal.image_width, cal.image_height), (640, 480))
        self.assertAlmostEqual(cal.baseline_m, 0.1, places=9)
        self.assertAlmostEqual(cal.focal_length_px, 500.0, delta=1.0)
        self.assertEqual(list(cal.parameters.translation_m), [-0.1, 0, 0])
        self.assertEqual(list(cal.parameters.rotation), [1, 0, 0, 0, 1, 0, 0, 0, 1])
        self.assertGreater(cal.create_time.seconds, 1_600_000_000)

        got = self.stub.GetCalibration(pb.GetCalibrationRequest(calibration_id="rig"), timeout=10)
        self.assertEqual(got, cal)
        listed = self.stub.ListCalibrations(pb.ListCalibrationsRequest(), timeout=10)
        self.assertIn("rig", [c.calibration_id for c in listed.calibrations])
        self.assertEqual(len(listed.unreadable), 0)
        self.assert_code(lambda: self.stub.Calibrate(
            pb.CalibrateRequest(calibration_id="rig", parameters=params), timeout=30),
            CODE.ALREADY_EXISTS, "rig")

        self.stub.DeleteCalibration(pb.DeleteCalibrationRequest(calibration_id="rig"), timeout=10)
        self.assert_code(lambda: self.stub.GetCalibration(
            pb.GetCalibrationRequest(calibration_id="rig"), timeout=10), CODE.NOT_FOUND, "rig")
        self.assert_code(lambda: self.stub.DeleteCalibration(
            pb.DeleteCalibrationRequest(calibration_id="rig"), timeout=10), CODE.NOT_FOUND)
        listed = self.stub.ListCalibrations(pb.ListCalibrationsRequest(), timeout=10)
        self.assertNotIn("rig", [c.calibration_id for c in listed.calibrations])

    def test_register_get_list_estimate(self):
        container = self.register("grpc-box")
        self.assertEqual(container.container_id, "grpc-box")
        self.assertEqual(container.registered_from, pb.SCAN_KIND_CLOUD)
        self.assertAlmostEqual(container.struck_capacity_m3, box_scene.STRUCK_M3,
                               delta=0.02 * box_scene.STRUCK_M3)
        self.assertAlmostEqual(container.opening_area_m2, 0.96, delta=1e-6)
        self.assertEqual(len(container.opening_corners), 4)
        self.assertFalse(container.HasField("max_range_m"))

        got = self.stub.GetContainer(pb.GetContainerRequest(container_id="grpc-box"), timeout=10)
        self.assertEqual(got, container)
        listed = self.stub.ListContainers(pb.ListContainersRequest(), timeout=10)
        self.assertIn("grpc-box", [c.container_id for c in listed.containers])
        self.assertEqual(len(listed.unreadable), 0)

        for fill in (0.0, 0.15, 0.3, 0.5):
            with self.subTest(fill=fill):
                est = self.stub.EstimateVolume(pb.EstimateVolumeRequest(
                    container_id="grpc-box", scan=cloud(filled_box(fill)), request_id=f"f{fill}",
                    material_density_kg_m3=1500), timeout=60)
                self.assertLess(abs(est.volume_m3 - truth_m3(fill)),
                                TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3,
                                f"fill {fill}: {est.volume_m3} vs {truth_m3(fill)}")
                self.assertEqual(est.container_id, "grpc-box")
                self.assertEqual(est.request_id, f"f{fill}")
                self.assertEqual(est.method, pb.ESTIMATION_METHOD_HEIGHTMAP)
                self.assertTrue(est.HasField("mass_kg"))
                self.assertAlmostEqual(est.mass_kg, 1500 * est.volume_m3, places=6)
                self.assertTrue(est.alignment.converged)
                self.assertGreater(est.alignment.fitness, 0.9)
                self.assertGreater(est.timings.total_ms, 0)
        est = self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id="grpc-box", scan=cloud(filled_box(0.2))), timeout=60)
        self.assertFalse(est.HasField("mass_kg"))

    def test_stream_estimates_keeps_order_and_survives_a_bad_scan(self):
        self.register("stream-box")
        fills = [0.1, 0.25, None, 0.4, 0.05]  # None: garbage cloud bytes
        requests = []
        for i, fill in enumerate(fills):
            data = os.urandom(20000) if fill is None else filled_box(fill, seed=20 + i)
            requests.append(pb.EstimateVolumeRequest(container_id="stream-box", scan=cloud(data),
                                                     request_id=f"scan-{i}"))
        answers = list(self.stub.StreamEstimates(iter(requests), timeout=120))
        self.assertEqual([a.sequence for a in answers], [0, 1, 2, 3, 4])
        self.assertEqual([a.request_id for a in answers], [f"scan-{i}" for i in range(5)])
        for answer, fill in zip(answers, fills):
            if fill is None:
                self.assertEqual(answer.WhichOneof("result"), "error", answer)
                self.assertEqual(answer.error.code, 3)  # INVALID_ARGUMENT
                self.assertIn("scan.cloud.data", answer.error.message)
                details = unpack_details(answer.error)
                self.assertEqual(details["ErrorInfo"].metadata["field"], "scan.cloud.data")
                self.assertEqual(details["BadRequest"].field_violations[0].field,
                                 "scan.cloud.data")
            else:
                self.assertEqual(answer.WhichOneof("result"), "estimate", answer.error)
                self.assertEqual(answer.estimate.request_id, answer.request_id)
                self.assertLess(abs(answer.estimate.volume_m3 - truth_m3(fill)),
                                TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3, f"fill {fill}")

    def test_errors_carry_the_right_code_and_field(self):
        self.register("err-box")
        scan = cloud(filled_box(0.2))
        stub = self.stub
        cases = [
            ("unknown container estimate", CODE.NOT_FOUND, ["container_id", "nope"],
             lambda: stub.EstimateVolume(pb.EstimateVolumeRequest(container_id="nope", scan=scan),
                                         timeout=30)),
            ("unknown container get", CODE.NOT_FOUND, ["nope"],
             lambda: stub.GetContainer(pb.GetContainerRequest(container_id="nope"), timeout=10)),
            ("unknown container delete", CODE.NOT_FOUND, ["nope"],
             lambda: stub.DeleteContainer(pb.DeleteContainerRequest(container_id="nope"),
                                          timeout=10)),
            ("stereo scan of a cloud container", CODE.FAILED_PRECONDITION, ["scan.stereo", "err-box"],
             lambda: stub.EstimateVolume(pb.EstimateVolumeRequest(
                 container_id="err-box", scan=pb.Scan(stereo=pb.StereoScan(
                     left=b"x", right=b"y", calibration_id="nope"))), timeout=30)),
            ("unknown calibration", CODE.NOT_FOUND, ["scan.stereo.calibration_id"],
             lambda: stub.RegisterContainer(pb.RegisterContainerRequest(
                 container_id="stereo-box", scan=pb.Scan(stereo=pb.StereoScan(
                     left=b"x", right=b"y", calibration_id="nope")),
                 opening=pb.Opening(pixel_corners=[pb.PixelPoint(u=1, v=2)] * 4)), timeout=30)),
            ("3 corners", CODE.INVALID_ARGUMENT, ["opening.corners"],
             lambda: stub.RegisterContainer(pb.RegisterContainerRequest(
                 container_id="three", scan=cloud(self.empty),
                 opening=box_opening(box_scene.opening_corners()[:3])), timeout=30)),
            ("path-like id", CODE.INVALID_ARGUMENT, ["container_id"],
             lambda: stub.RegisterContainer(pb.RegisterContainerRequest(
                 container_id="../x", scan=cloud(self.empty), opening=box_opening()), timeout=30)),
            ("path-like id get", CODE.INVALID_ARGUMENT, ["container_id"],
             lambda: stub.GetContainer(pb.GetContainerRequest(container_id="../x"), timeout=10)),
            ("duplicate", CODE.ALREADY_EXISTS, ["container_id", "err-box"],
             lambda: self.register("err-box")),
            ("garbage cloud", CODE.INVALID_ARGUMENT, ["scan.cloud.data"],
             lambda: stub.EstimateVolume(pb.EstimateVolumeRequest(
                 container_id="err-box", scan=cloud(os.urandom(4096))), timeout=30)),
            ("no scan", CODE.INVALID_ARGUMENT, ["scan"],
             lambda: stub.EstimateVolume(pb.EstimateVolumeRequest(container_id="err-box"),
                                         timeout=30)),
            ("zero cell", CODE.INVALID_ARGUMENT, ["grid_cell_m"],
             lambda: stub.EstimateVolume(pb.EstimateVolumeRequest(
                 container_id="err-box", scan=scan, grid_cell_m=0.0), timeout=30)),
            ("bad range", CODE.INVALID_ARGUMENT, ["max_range_m"],
             lambda: self.register("neg-range", max_range_m=-1.0)),
        ]
        for name, code, fragments, call in cases:
            with self.subTest(name):
                self.assert_code(call, code, *fragments)
        # None of the refused registrations left anything behind.
        ids = [c.container_id for c in
               stub.ListContainers(pb.ListContainersRequest(), timeout=10).containers]
        for cid in ("three", "neg-range"):
            self.assertNotIn(cid, ids)
        # The duplicate did not replace the original.
        self.assertFalse(stub.GetContainer(pb.GetContainerRequest(container_id="err-box"),
                                           timeout=10).HasField("max_range_m"))

    def test_errors_carry_google_rpc_status_details(self):
        err = self.assert_code(lambda: self.stub.GetContainer(
            pb.GetContainerRequest(container_id="../x"), timeout=10), CODE.INVALID_ARGUMENT)
        status = rpc_status(err)
        self.assertEqual(status.code, 3)
        self.assertEqual(status.message, err.details())
        details = unpack_details(status)
        self.assertEqual(details["ErrorInfo"].reason, "INVALID_ARGUMENT")
        self.assertEqual(details["ErrorInfo"].domain, "soilvol")
        self.assertEqual(details["ErrorInfo"].metadata["field"], "container_id")
        self.assertEqual(details["BadRequest"].field_violations[0].field, "container_id")
        self.assertNotIn("RetryInfo", details)
        err = self.assert_code(lambda: self.stub.GetContainer(
            pb.GetContainerRequest(container_id="absent"), timeout=10), CODE.NOT_FOUND)
        self.assertEqual(set(unpack_details(rpc_status(err))), {"ErrorInfo"})

    def test_retried_creates_return_the_first_result(self):
        first = self.register("", request_id="retry-7f3a")
        self.assertRegex(first.container_id, r"^ctr-[0-9a-f]{12}$")
        self.assertEqual(first.create_request_id, "retry-7f3a")
        again = self.register("", request_id="retry-7f3a")
        self.assertEqual(again, first)
        other = self.register("", request_id="retry-other")
        self.assertNotEqual(other.container_id, first.container_id)
        # With a client-chosen id, a retry returns the entry instead of ALREADY_EXISTS...
        named = self.register("retry-named", request_id="retry-n1")
        self.assertEqual(self.register("retry-named", request_id="retry-n1"), named)
        # ...and another request for the same id is still a conflict.
        self.assert_code(lambda: self.register("retry-named", request_id="retry-n2"),
                         CODE.ALREADY_EXISTS, "retry-named")
        cal = self.stub.Calibrate(pb.CalibrateRequest(request_id="cal-retry", parameters=PARAMS),
                                  timeout=30)
        self.assertEqual(self.stub.Calibrate(pb.CalibrateRequest(
            request_id="cal-retry", parameters=PARAMS), timeout=30), cal)
        self.assert_code(lambda: self.register("", request_id="not a valid id"),
                         CODE.INVALID_ARGUMENT, "request_id")

    def test_etags_guard_overwrite_and_delete(self):
        first = self.register("etag-box", overwrite=True)
        self.assertRegex(first.etag, r"^[0-9a-f]{16}$")
        got = self.stub.GetContainer(pb.GetContainerRequest(container_id="etag-box"), timeout=10)
        self.assertEqual(got.etag, first.etag)
        err = self.assert_code(lambda: self.register("etag-box", overwrite=True, etag="0" * 16),
                               CODE.ABORTED, "etag")
        self.assertEqual(unpack_details(rpc_status(err))["ErrorInfo"].reason, "ETAG_MISMATCH")
        second = self.register("etag-box", overwrite=True, etag=first.etag)
        self.assertNotEqual(second.etag, first.etag)
        self.assert_code(lambda: self.register("etag-box", etag=second.etag),
                         CODE.INVALID_ARGUMENT, "etag")
        self.assert_code(lambda: self.stub.DeleteContainer(pb.DeleteContainerRequest(
            container_id="etag-box", etag=first.etag), timeout=10), CODE.ABORTED, "etag")
        self.stub.DeleteContainer(pb.DeleteContainerRequest(container_id="etag-box",
                                                            etag=second.etag), timeout=10)
        self.assert_code(lambda: self.stub.GetContainer(
            pb.GetContainerRequest(container_id="etag-box"), timeout=10), CODE.NOT_FOUND)

    def test_lists_page_in_id_order(self):
        for i in range(5):
            self.stub.Calibrate(pb.CalibrateRequest(calibration_id=f"page-{i}", overwrite=True,
                                                    parameters=PARAMS), timeout=30)
        seen, token = [], ""
        while True:
            page = self.stub.ListCalibrations(
                pb.ListCalibrationsRequest(page_size=2, page_token=token), timeout=10)
            self.assertLessEqual(len(page.calibrations), 2)
            seen += [c.calibration_id for c in page.calibrations]
            token = page.next_page_token
            if not token:
                break
        self.assertEqual(seen, sorted(set(seen)))
        self.assertLessEqual({f"page-{i}" for i in range(5)}, set(seen))
        self.assert_code(lambda: self.stub.ListCalibrations(
            pb.ListCalibrationsRequest(page_token="forged"), timeout=10),
            CODE.INVALID_ARGUMENT, "page_token")

    def test_server_info_version_and_request_ids(self):
        info, call = self.stub.GetServerInfo.with_call(
            pb.GetServerInfoRequest(), timeout=10, metadata=[("x-request-id", "fleet-17")])
        self.assertEqual(dict(call.initial_metadata())["x-request-id"], "fleet-17")
        self.assertEqual(info.api, "soilvol.v1.SoilVolume")
        self.assertGreater(info.start_time.seconds, 1_600_000_000)
        version = subprocess.run([os.environ["SOILVOL_SERVER_BIN"], "--version"], check=True,
                                 capture_output=True, text=True).stdout
        self.assertIn(f" {info.version} (revision {info.revision}, ", version)
        _, call = self.stub.GetServerInfo.with_call(pb.GetServerInfoRequest(), timeout=10)
        self.assertRegex(dict(call.initial_metadata())["x-request-id"], r"^[0-9a-f]{32}$")

    def test_kinematic_pose_starts_the_alignment_and_is_checked(self):
        container = self.register("kinematic-box", overwrite=True)
        self.assertAlmostEqual(container.container_pose.orientation.w, 1.0, delta=1e-3)
        # The bucket has moved far from where it was registered; the machine knows where.
        shift, yaw = (0.35, -0.25, 0.05), 12.0
        scan = cloud(box_scene.encode_ply(box_scene.box_scan(0.3, seed=5, shift=shift,
                                                             yaw_deg=yaw)))
        est = self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id="kinematic-box", scan=scan, container_pose=pb.KinematicPose(
                pose=yaw_pose(*shift, yaw), position_sigma_m=0.05, orientation_sigma_deg=3)),
            timeout=60)
        self.assertLess(abs(est.volume_m3 - truth_m3(0.3)),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3)
        self.assertLess(est.pose_difference.distance_m, 0.02)
        self.assertLess(est.pose_difference.rotation_deg, 1.0)
        found = est.container_pose.position_m
        self.assertLess(math.dist((found.x, found.y, found.z), shift), 0.02)
        self.assertAlmostEqual(est.container_pose.orientation.z, math.sin(math.radians(yaw) / 2),
                               delta=0.01)
        # Without a kinematic pose the response still says where the container was found.
        plain = self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id="kinematic-box", scan=cloud(filled_box(0.2))), timeout=60)
        self.assertFalse(plain.HasField("pose_difference"))
        self.assertAlmostEqual(plain.container_pose.position_m.x, 0.03, delta=0.01)
        # A pose the scan contradicts beyond its stated accuracy is refused, not averaged.
        self.assert_code(lambda: self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id="kinematic-box", scan=scan, container_pose=pb.KinematicPose(
                pose=yaw_pose(shift[0] + 0.12, shift[1], shift[2], yaw), position_sigma_m=0.01,
                orientation_sigma_deg=0.5)), timeout=60), CODE.FAILED_PRECONDITION)
        for bad, field in [
                (pb.KinematicPose(pose=pb.Pose(orientation=pb.Quaternion(w=2))),
                 "container_pose.pose.orientation"),
                (pb.KinematicPose(position_sigma_m=-1), "container_pose.position_sigma_m"),
                (pb.KinematicPose(orientation_sigma_deg=90), "container_pose.orientation_sigma_deg"),
                (pb.KinematicPose(pose=pb.Pose(position_m=pb.Point3(x=math.inf))),
                 "container_pose.pose")]:
            with self.subTest(field):
                self.assert_code(lambda: self.stub.EstimateVolume(pb.EstimateVolumeRequest(
                    container_id="kinematic-box", scan=scan, container_pose=bad), timeout=60),
                    CODE.INVALID_ARGUMENT, field)

    def test_heightmap_and_distribution_describe_the_load(self):
        self.register("heap-box", overwrite=True)
        # Soil 0.2 m deep, plus a heap on the +x end: the load leans to +x.
        points = box_scene.box_scan(0.2, seed=11)
        heap = (points[:, 0] > 0.2) & (points[:, 2] > -box_scene.DEPTH + 0.19) & \
            (abs(points[:, 0]) < box_scene.INNER_L / 2 - 0.01) & \
            (abs(points[:, 1]) < box_scene.INNER_W / 2 - 0.01)
        points[heap, 2] += 0.15
        est = self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id="heap-box", scan=cloud(box_scene.encode_ply(points))), timeout=60)
        h = est.heightmap
        self.assertEqual(len(h.heights_f32le), 4 * h.cols * h.rows)
        self.assertAlmostEqual(h.cell_m, est.cells.cell_m)
        heights = struct.unpack(f"<{h.cols * h.rows}f", h.heights_f32le)
        observed = [v for v in heights if not math.isnan(v)]
        self.assertGreater(len(observed), 0.8 * est.cells.total)
        # Heights integrate to the volume over the observed cells (cells straddling the rim
        # count whole here, so a few per cent over).
        self.assertAlmostEqual(sum(observed) * h.cell_m ** 2, est.volume_m3,
                               delta=0.1 * est.volume_m3)
        # Cells on the heap side are higher than on the other.
        column = lambda x: int((x - h.origin_x_m) / h.cell_m)  # noqa: E731
        row = int((0.0 - h.origin_y_m) / h.cell_m)
        self.assertAlmostEqual(heights[row * h.cols + column(0.4)], 0.35, delta=0.03)
        self.assertAlmostEqual(heights[row * h.cols + column(-0.4)], 0.2, delta=0.03)
        d = est.distribution
        self.assertGreater(d.centre_x_m, 0.03)
        self.assertAlmostEqual(d.centre_y_m, 0.0, delta=0.02)
        self.assertGreater(d.positive_x_share, 0.55)
        self.assertAlmostEqual(d.positive_y_share, 0.5, delta=0.03)
        self.assertGreater(d.asymmetry, 0.05)
        lean = self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id="heap-box", scan=cloud(box_scene.encode_ply(points)),
            omit_heightmap=True), timeout=60)
        self.assertFalse(lean.HasField("heightmap"))
        self.assertEqual(lean.distribution, d)

    def test_load_targets_give_each_estimate_its_status(self):
        truth = truth_m3(0.5 * box_scene.DEPTH)
        created = self.register(
            "target-box", overwrite=True, display_name="Truck 7",
            labels={"site": "north-pit"},
            material=pb.Material(name="clay", density_kg_m3=1600, bulking_factor=1.25),
            load_targets=pb.LoadTargets(volume_m3=truth, under_tolerance=0.1,
                                        over_tolerance=0.1, carryback_m3=0.01))
        self.assertEqual(created.display_name, "Truck 7")
        self.assertEqual(dict(created.labels), {"site": "north-pit"})
        self.assertEqual(created.update_time, created.create_time)
        est = lambda fill: self.stub.EstimateVolume(pb.EstimateVolumeRequest(  # noqa: E731
            container_id="target-box", scan=cloud(box_scene.encode_ply(
                box_scene.box_scan(fill * box_scene.DEPTH, seed=5))), omit_heightmap=True),
            timeout=60)
        half = est(0.5)
        self.assertEqual(half.load.status, pb.LOAD_STATUS_LOADED_OK)
        self.assertAlmostEqual(half.load.target_ratio, half.volume_m3 / truth, places=9)
        self.assertAlmostEqual(half.mass_kg, 1600 * half.volume_m3, places=6)
        self.assertAlmostEqual(half.load.mass_uncertainty_kg, 1600 * half.uncertainty_m3,
                               places=6)
        self.assertAlmostEqual(half.load.bank_volume_m3, half.volume_m3 / 1.25, places=9)
        self.assertGreater(half.load.status_probability, 0.9)
        self.assertEqual(est(0.25).load.status, pb.LOAD_STATUS_UNDERLOADED)
        self.assertEqual(est(0.7).load.status, pb.LOAD_STATUS_OVERLOADED)
        empty = est(0.0)
        self.assertEqual(empty.load.status, pb.LOAD_STATUS_EMPTY, empty.volume_m3)
        self.assertGreaterEqual(empty.load.empty_threshold_m3, 2 * empty.uncertainty_m3)
        # A payload target through the density: 0.5 of the struck volume in clay is light.
        updated = self.stub.UpdateContainer(pb.UpdateContainerRequest(
            container=pb.Container(container_id="target-box", etag=created.etag,
                                   load_targets=pb.LoadTargets(payload_kg=2 * 1600 * truth))),
            timeout=30)
        self.assertNotEqual(updated.etag, created.etag)
        self.assertEqual(updated.display_name, "Truck 7")  # not in the implied mask
        self.assertEqual(updated.struck_capacity_m3, created.struck_capacity_m3)
        self.assertGreaterEqual(updated.update_time.ToNanoseconds(),
                                created.create_time.ToNanoseconds())
        self.assertEqual(est(0.5).load.status, pb.LOAD_STATUS_UNDERLOADED)
        # The request's density replaces the material's for one scan.
        heavy = self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id="target-box", material_density_kg_m3=3600, omit_heightmap=True,
            scan=cloud(box_scene.encode_ply(box_scene.box_scan(0.5 * box_scene.DEPTH, seed=5)))),
            timeout=60)
        self.assertEqual(heavy.load.status, pb.LOAD_STATUS_OVERLOADED)

    def test_update_container_follows_aip_134(self):
        created = self.register("update-box", overwrite=True, display_name="Bucket",
                                labels={"a": "1", "b": "2"},
                                material=pb.Material(name="sand", density_kg_m3=1500))
        update = lambda mask, **fields: self.stub.UpdateContainer(  # noqa: E731
            pb.UpdateContainerRequest(
                container=pb.Container(container_id="update-box", **fields),
                update_mask=field_mask_pb2.FieldMask(paths=mask)), timeout=30)
        # A path inside material keeps its other fields; labels are replaced whole.
        got = update(["material.density_kg_m3", "labels"],
                     material=pb.Material(density_kg_m3=1700), labels={"c": "3"})
        self.assertEqual(got.material.name, "sand")
        self.assertEqual(got.material.density_kg_m3, 1700)
        self.assertEqual(dict(got.labels), {"c": "3"})
        self.assertEqual(got.display_name, "Bucket")
        # A masked field that the message leaves unset is cleared.
        got = update(["display_name"])
        self.assertEqual(got.display_name, "")
        self.assertEqual(self.stub.GetContainer(pb.GetContainerRequest(
            container_id="update-box"), timeout=30), got)
        # "*" replaces every setting.
        got = update(["*"], display_name="B2")
        self.assertEqual((got.display_name, len(got.labels), got.HasField("material")),
                         ("B2", 0, False))
        self.assertEqual(got.struck_capacity_m3, created.struck_capacity_m3)
        self.assert_code(lambda: update(["struck_capacity_m3"]), CODE.INVALID_ARGUMENT,
                         "update_mask", "names nothing")
        # Output-only fields in a mask are ignored (a client sends back what it read).
        got = update(["display_name", "struck_capacity_m3", "etag"], display_name="B3",
                     struck_capacity_m3=99)
        self.assertEqual(got.display_name, "B3")
        self.assertEqual(got.struck_capacity_m3, created.struck_capacity_m3)
        self.assert_code(lambda: update(["material.colour"]), CODE.INVALID_ARGUMENT,
                         "update_mask", "no field")
        self.assert_code(lambda: update([]), CODE.INVALID_ARGUMENT, "update_mask")
        self.assert_code(lambda: update(["material"], material=pb.Material(density_kg_m3=-1)),
                         CODE.INVALID_ARGUMENT, "container.material.density_kg_m3")
        self.assert_code(lambda: update(["load_targets"],
                                        load_targets=pb.LoadTargets(payload_kg=1000)),
                         CODE.INVALID_ARGUMENT, "container.load_targets.payload_kg")
        self.assert_code(lambda: update(["labels"], labels={"Bad Key": "x"}),
                         CODE.INVALID_ARGUMENT, "container.labels")
        self.assert_code(lambda: update(["display_name"], etag="0000000000000000"),
                         CODE.ABORTED, "etag")
        self.assert_code(lambda: self.stub.UpdateContainer(pb.UpdateContainerRequest(
            container=pb.Container(container_id="no-such-box", display_name="x")), timeout=30),
            CODE.NOT_FOUND, "container.container_id")
        self.assert_code(lambda: self.register("bad-labels", labels={"k": "a b"}),
                         CODE.INVALID_ARGUMENT, "labels")

    def test_every_rpc_of_the_service_is_served(self):
        service = pb.DESCRIPTOR.services_by_name["SoilVolume"]
        for method in service.methods:
            if method.client_streaming:
                continue
            with self.subTest(method.name):
                if method.server_streaming:  # a watch: it answers with its initial metadata
                    stream = self.channel.unary_stream(
                        f"/{service.full_name}/{method.name}",
                        request_serializer=lambda m: m.SerializeToString(),
                        response_deserializer=lambda b: b)(
                            getattr(pb, method.input_type.name)(), timeout=30)
                    try:
                        stream.initial_metadata()
                        if stream.done():  # refused at once (an open watch is not done)
                            self.assertNotEqual(stream.code(), CODE.UNIMPLEMENTED, method.name)
                    finally:
                        stream.cancel()
                    continue
                call = self.channel.unary_unary(
                    f"/{service.full_name}/{method.name}",
                    request_serializer=lambda m: m.SerializeToString(),
                    response_deserializer=lambda b: b)
                try:
                    call(getattr(pb, method.input_type.name)(), timeout=30)
                except grpc.RpcError as e:
                    self.assertNotEqual(e.code(), CODE.UNIMPLEMENTED, method.name)

    def test_long_stream_survives_client_keepalive_pings_every_10_s(self):
        # gRPC's default server policy answers pings more often than every 5 min with GOAWAY
        # too_many_pings, which kills a long stream; soilvol permits one every 10 s, also
        # without calls. Three pings pass while the stream waits.
        self.register("keepalive-box", overwrite=True)
        channel = self.server.channel(grpc, options=[
            ("grpc.keepalive_time_ms", 10000), ("grpc.keepalive_timeout_ms", 5000),
            ("grpc.keepalive_permit_without_calls", 1), ("grpc.http2.max_pings_without_data", 0)])
        stub = pb_grpc.SoilVolumeStub(channel)
        sent = []

        def scans():
            for i in range(2):
                if i:
                    time.sleep(35)  # pings at 10, 20 and 30 s with the stream open
                sent.append(i)
                yield pb.EstimateVolumeRequest(container_id="keepalive-box",
                                               scan=cloud(filled_box(0.2, seed=40 + i)),
                                               request_id=f"keepalive-{i}")
        try:
            answers = list(stub.StreamEstimates(scans(), timeout=120))
        finally:
            channel.close()
        self.assertEqual([a.request_id for a in answers], ["keepalive-0", "keepalive-1"])
        self.assertTrue(all(a.WhichOneof("result") == "estimate" for a in answers), answers)

    def test_paper_method_with_small_cells_is_refused_or_right(self):
        # grid_cell_m is accepted down to 5 mm, but most 1 cm cells of this 12 mm scan hold
        # fewer than 3 points and take the averaged planes of far cells, extrapolated: the paper
        # method answers 0.50 m3 for 0.19 m3 of soil (22 m3 with 5 mm cells), uncertainty
        # 0.001 m3. Such a request must be refused naming grid_cell_m, or measured right.
        self.register("paper-box")
        request = pb.EstimateVolumeRequest(container_id="paper-box", scan=cloud(filled_box(0.2)),
                                           method=pb.ESTIMATION_METHOD_PAPER, grid_cell_m=0.01)
        try:
            est = self.stub.EstimateVolume(request, timeout=60)
        except grpc.RpcError as e:
            self.assertIn(e.code(), (CODE.INVALID_ARGUMENT, CODE.FAILED_PRECONDITION))
            self.assertIn("grid_cell_m", e.details())
            return
        self.assertLess(abs(est.volume_m3 - truth_m3(0.2)),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3,
                        f"{est.volume_m3:.3f} m3 (fill ratio {est.fill_ratio:.1f}) for "
                        f"{truth_m3(0.2):.3f} m3 of soil, uncertainty {est.uncertainty_m3} m3")

    def test_deadlines(self):
        self.register("grpc-deadline-box")
        method = {"method": "EstimateVolume", "transport": "grpc"}
        ok_before = server_metric(self.server, "soilvol_requests_total", code="OK", **method)
        late_before = server_metric(self.server, "soilvol_requests_total",
                                    code="DEADLINE_EXCEEDED", **method)
        # 5 mm cells take over half a second to estimate (the scan itself is small, 5x that under
        # the sanitizers): the server must not answer OK after the caller's 150 ms are over, but
        # record DEADLINE_EXCEEDED.
        slow = pb.EstimateVolumeRequest(container_id="grpc-deadline-box", scan=cloud(filled_box(0.2)),
                                        grid_cell_m=0.005)
        # The deadline stretches with the engine (sanitizers). A call that reaches the server after
        # its deadline is dropped by gRPC before any handler sees it, and is not counted: on a
        # loaded machine that can happen, so the call is tried up to three times.
        recorded = False
        for _ in range(3):
            self.assert_code(lambda: self.stub.EstimateVolume(slow, timeout=0.15 * TIME_SCALE),
                             CODE.DEADLINE_EXCEEDED)
            recorded = wait_until(lambda: server_metric(
                self.server, "soilvol_requests_total", code="DEADLINE_EXCEEDED", **method)
                > late_before, timeout_s=5 * TIME_SCALE)
            if recorded:
                break
        self.assertTrue(recorded, "the server never recorded DEADLINE_EXCEEDED")
        self.assertEqual(server_metric(self.server, "soilvol_requests_total", code="OK", **method),
                         ok_before)
        if self.server.own_process:
            self.assertTrue(any("deadline expired" in line for line in self.server.log))

        small = pb.EstimateVolumeRequest(container_id="grpc-deadline-box", scan=cloud(filled_box(0.2)))
        self.assert_code(lambda: self.stub.EstimateVolume(small, timeout=0.001),
                         CODE.DEADLINE_EXCEEDED)
        # Without a tight deadline the same call works.
        est = self.stub.EstimateVolume(small, timeout=60)
        self.assertLess(abs(est.volume_m3 - truth_m3(0.2)),
                        TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3)

    def test_health_check(self):
        check, _ = health_methods(self.channel)
        for service in ("", "soilvol.v1.SoilVolume", "liveness"):
            with self.subTest(service=service):
                self.assertEqual(check(service, timeout=10), SERVING)
        with self.assertRaises(grpc.RpcError) as ctx:
            check("nope", timeout=10)
        self.assertEqual(ctx.exception.code(), CODE.NOT_FOUND)
        # Watch answers an unknown name with SERVICE_UNKNOWN (3) instead of failing.
        _, watch = health_methods(self.channel)
        stream = watch("nope", timeout=10)
        self.assertEqual(next(stream), 3)
        stream.cancel()


@needs_own_server
class MessageLimit(unittest.TestCase):
    def test_oversize_request_is_refused_and_server_keeps_serving(self):
        with Server(args=["--workers", "1", "--max-message-mb", "1"]) as server:
            with server.channel(grpc) as channel:
                stub = pb_grpc.SoilVolumeStub(channel)
                big = pb.RegisterContainerRequest(container_id="big",
                                                  scan=cloud(os.urandom(2 << 20)),
                                                  opening=box_opening())
                with self.assertRaises(grpc.RpcError) as ctx:
                    stub.RegisterContainer(big, timeout=30)
                self.assertEqual(ctx.exception.code(), CODE.RESOURCE_EXHAUSTED,
                                 ctx.exception.details())
                # A request under the limit (about 0.5 MiB) on the same channel still works.
                empty = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))
                self.assertLess(len(empty), 1 << 20)
                small = pb.RegisterContainerRequest(container_id="small", scan=cloud(empty),
                                                    opening=box_opening())
                self.assertEqual(stub.RegisterContainer(small, timeout=60).container_id, "small")
                ids = [c.container_id for c in
                       stub.ListContainers(pb.ListContainersRequest(), timeout=10).containers]
                self.assertEqual(ids, ["small"])
            self.assertTrue(server.alive())


@needs_own_server
class HealthWatch(unittest.TestCase):
    def test_watch_reports_shutdown(self):
        with Server(args=["--workers", "1"]) as server:
            with server.channel(grpc) as channel:
                _, watch = health_methods(channel)
                stream = watch("", timeout=30)
                self.assertEqual(next(stream), SERVING)
                sent = time.monotonic()
                server.proc.send_signal(signal.SIGTERM)
                seen = []
                try:
                    for status in stream:
                        seen.append(status)
                        if status == NOT_SERVING:
                            break
                except grpc.RpcError as e:  # the stream may end with the server instead
                    self.assertNotEqual(e.code(), CODE.DEADLINE_EXCEEDED, "watch saw no change")
                self.assertLess(time.monotonic() - sent, 5.0)
                self.assertNotIn(SERVING, seen, "SERVING again after SIGTERM")
                stream.cancel()
            self.assertEqual(server.proc.wait(15), 0)
        self.assertTrue(any(" stopped " in f" {line} " for line in server.log), server.log)

if __name__ == "__main__":
    unittest.main(verbosity=2)
