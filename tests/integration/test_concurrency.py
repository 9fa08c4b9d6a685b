"""The server under concurrent load, shared data directories, kills and shutdown: real server
processes driven over gRPC (python3-grpcio) and REST (http.client, urllib) from many threads."""
import collections
import http.client
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import (TIME_SCALE, Server, cloud_scan, load_grpc, needs_own_server,  # noqa: E402
                     server_metric, wait_until)  # noqa: E402

grpc, pb, pb_grpc = load_grpc()

TOLERANCE_OF_STRUCK = 0.04  # as test_rest.py
CODE = grpc.StatusCode
RESOURCE_EXHAUSTED = 8  # google.rpc.Code, as in REST error bodies


def cloud(ply):
    return pb.Scan(cloud=pb.CloudScan(data=ply))


def box_opening():
    return pb.Opening(corners=[pb.Point3(x=x, y=y, z=z) for x, y, z in box_scene.opening_corners()])


def filled_box(fill, seed=7, step=0.012):
    return box_scene.encode_ply(box_scene.box_scan(fill, seed=seed, step=step,
                                                   shift=(0.03, -0.02, 0.01), yaw_deg=2.0))


def volume_error(volume_m3, fill):
    return abs(volume_m3 - box_scene.INNER_L * box_scene.INNER_W * fill)


MAX_ERROR_M3 = TOLERANCE_OF_STRUCK * box_scene.STRUCK_M3
EMPTY = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))


def register_request(cid, scan=EMPTY, **extra):
    return pb.RegisterContainerRequest(container_id=cid, scan=cloud(scan), opening=box_opening(),
                                       **extra)


def requests_total(server, code, method="EstimateVolume", transport="grpc"):
    return server_metric(server, "soilvol_requests_total", code=code, method=method,
                         transport=transport)


class Client:
    """A channel and stub to one server."""

    def __init__(self, server):
        self.channel = server.channel(grpc)
        self.stub = pb_grpc.SoilVolumeStub(self.channel)

    def close(self):
        self.channel.close()

    def code_of(self, call, *args, **kwargs):
        """(status code, response or None) of one call."""
        try:
            return CODE.OK, call(*args, **kwargs)
        except grpc.RpcError as e:
            return e.code(), None


@needs_own_server
class Backpressure(unittest.TestCase):
    """--workers 2 --max-queue 2: four calls fit, the rest are refused at once, none are lost."""
    CALLS = 24
    FILL = 0.2

    @classmethod
    def setUpClass(cls):
        cls.server = Server(args=["--workers", "2", "--max-queue", "2"]).start()
        cls.client = Client(cls.server)
        cls.client.stub.RegisterContainer(register_request("load-box"), timeout=60)
        cls.scan = filled_box(cls.FILL)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.server.close()

    def check_outcomes(self, outcomes):
        """outcomes: (True, volume) or (False, (code, message)) per call."""
        self.assertEqual(len(outcomes), self.CALLS)
        ok = [v for good, v in outcomes if good]
        refused = [m for good, m in outcomes if not good]
        # Two running and two waiting always fit: the first four calls cannot be refused.
        self.assertGreaterEqual(len(ok), 4, outcomes)
        self.assertGreaterEqual(len(refused), 1, "nothing was refused: the queue is unbounded?")
        for volume in ok:
            self.assertLess(volume_error(volume, self.FILL), MAX_ERROR_M3)
        for message in refused:
            self.assertEqual(message[0], RESOURCE_EXHAUSTED, message)
            self.assertIn("busy", message[1])
        return len(ok), len(refused)

    def sequential_calls_succeed(self, estimate):
        for _ in range(3):
            good, value = estimate()
            self.assertTrue(good, value)
            self.assertLess(volume_error(value, self.FILL), MAX_ERROR_M3)

    def test_grpc_overload(self):
        stub = self.client.stub
        ok_before = requests_total(self.server, "OK")
        busy_before = requests_total(self.server, "RESOURCE_EXHAUSTED")
        request = pb.EstimateVolumeRequest(container_id="load-box", scan=cloud(self.scan))

        def outcome(future):
            try:
                return True, future.result().volume_m3
            except grpc.RpcError as e:
                return False, (e.code().value[0], e.details())

        futures = [stub.EstimateVolume.future(request, timeout=120) for _ in range(self.CALLS)]
        ok, refused = self.check_outcomes([outcome(f) for f in futures])
        self.sequential_calls_succeed(
            lambda: outcome(stub.EstimateVolume.future(request, timeout=60)))
        # Every refusal is counted, and only those.
        self.assertEqual(requests_total(self.server, "RESOURCE_EXHAUSTED") - busy_before, refused)
        self.assertEqual(requests_total(self.server, "OK") - ok_before, ok + 3)
        print(f"\ngrpc: {ok} answered, {refused} refused", file=sys.stderr)

    def test_rest_overload(self):
        ok_before = requests_total(self.server, "OK", transport="http")
        busy_before = requests_total(self.server, "RESOURCE_EXHAUSTED", transport="http")
        path = "/v1/containers/load-box:estimate"
        body = json.dumps({"scan": cloud_scan(self.scan)}).encode()
        start = threading.Barrier(self.CALLS)

        def call(connection):
            """One POST on an open connection, sent when every thread is ready."""
            start.wait(30)
            connection.request("POST", path, body, {"Content-Type": "application/json"})
            response = connection.getresponse()
            status, answer = response.status, json.loads(response.read())
            connection.close()
            if status == 200:
                return True, answer["volumeM3"]
            return False, (answer["code"], answer["message"]) if status == 429 else (status, answer)

        # The connections are opened one after the other first, so that the requests, not the
        # connection attempts, arrive together (see test_rest_listen_backlog_fits_a_burst).
        connections = []
        for _ in range(self.CALLS):
            connections.append(http.client.HTTPConnection("127.0.0.1", self.server.http_port,
                                                          timeout=120))
            connections[-1].connect()
        with ThreadPoolExecutor(self.CALLS) as pool:
            outcomes = list(pool.map(call, connections))
        ok, refused = self.check_outcomes(outcomes)

        def sequential():
            status, answer = self.server.rest("POST", path, raw=body)
            return status == 200, answer["volumeM3"] if status == 200 else answer

        self.sequential_calls_succeed(sequential)
        self.assertEqual(
            requests_total(self.server, "RESOURCE_EXHAUSTED", transport="http") - busy_before,
            refused)
        self.assertEqual(requests_total(self.server, "OK", transport="http") - ok_before, ok + 3)
        print(f"\nrest: {ok} answered, {refused} refused", file=sys.stderr)

    @unittest.skipUnless(shutil.which("ss"), "ss (iproute2) is not installed")
    def test_rest_listen_backlog_fits_a_burst(self):
        # A burst of new REST connections larger than the listen backlog is dropped by the
        # kernel (clients retry after 1 s) or, with SYN cookies, reset mid-request, instead of
        # being answered (429 included). The backlog should hold at least the connections the
        # gateway serves at once: 2 x (workers + max_queue) + 4 = 12 here.
        listing = subprocess.run(["ss", "-ltnH", f"sport = :{self.server.http_port}"],
                                 capture_output=True, text=True, check=True).stdout.split()
        self.assertEqual(listing[0], "LISTEN", listing)
        backlog = int(listing[2])  # Send-Q of a listening socket
        self.assertGreaterEqual(backlog, 12)

    def test_load_gauges_return_to_zero_when_idle(self):
        request = pb.EstimateVolumeRequest(container_id="load-box", scan=cloud(self.scan))
        self.client.stub.EstimateVolume(request, timeout=60)
        time.sleep(0.2)
        self.assertEqual(server_metric(self.server, "soilvol_in_flight"), 0)
        self.assertEqual(server_metric(self.server, "soilvol_queue_depth"), 0)


@needs_own_server
class SharedDataDir(unittest.TestCase):
    """Two server processes on one data directory: neither may serve a stale cached copy."""

    @classmethod
    def setUpClass(cls):
        cls.data_dir = tempfile.mkdtemp(prefix="soilvol-shared-")
        cls.a = Server(cls.data_dir, args=["--workers", "1"]).start()
        cls.b = Server(cls.data_dir, args=["--workers", "1"]).start()
        cls.ca, cls.cb = Client(cls.a), Client(cls.b)

    @classmethod
    def tearDownClass(cls):
        cls.ca.close()
        cls.cb.close()
        cls.a.stop()
        cls.b.stop()
        shutil.rmtree(cls.data_dir, ignore_errors=True)

    def estimate_ok(self, client, cid, fill=0.3):
        est = client.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id=cid, scan=cloud(filled_box(fill))), timeout=60)
        self.assertLess(volume_error(est.volume_m3, fill), MAX_ERROR_M3)

    def test_changes_on_one_server_are_seen_by_the_other(self):
        a, b = self.ca.stub, self.cb.stub
        get = pb.GetContainerRequest(container_id="shared")
        created = a.RegisterContainer(register_request("shared"), timeout=60)
        self.assertEqual(b.GetContainer(get, timeout=10), created)
        self.estimate_ok(self.cb, "shared")
        self.estimate_ok(self.ca, "shared")  # both now hold the model in their caches

        # Replaced on B (another scan, a range cut): A must serve the new one.
        other_scan = box_scene.encode_ply(box_scene.box_scan(0.0, seed=2))
        replaced = b.RegisterContainer(register_request("shared", scan=other_scan,
                                                        max_range_m=30.0, overwrite=True),
                                       timeout=60)
        seen = a.GetContainer(get, timeout=10)
        self.assertTrue(seen.HasField("max_range_m"))
        self.assertEqual(seen, replaced)
        listed = a.ListContainers(pb.ListContainersRequest(), timeout=10)
        self.assertEqual([c.max_range_m for c in listed.containers if c.container_id == "shared"],
                         [30.0])
        self.estimate_ok(self.ca, "shared")

        # Deleted on B: gone on A too, for every way of asking.
        b.DeleteContainer(pb.DeleteContainerRequest(container_id="shared"), timeout=10)
        self.assertEqual(self.ca.code_of(a.GetContainer, get, timeout=10)[0], CODE.NOT_FOUND)
        self.assertEqual(self.ca.code_of(a.EstimateVolume, pb.EstimateVolumeRequest(
            container_id="shared", scan=cloud(filled_box(0.3))), timeout=60)[0], CODE.NOT_FOUND)
        self.assertEqual(self.a.rest("GET", "/v1/containers/shared")[0], 404)
        listed = a.ListContainers(pb.ListContainersRequest(), timeout=10)
        self.assertNotIn("shared", [c.container_id for c in listed.containers])

    def test_calibrations_are_shared(self):
        params = pb.StereoParameters(
            image_width=640, image_height=480,
            left=pb.CameraIntrinsics(fx=500, fy=500, cx=320, cy=240),
            right=pb.CameraIntrinsics(fx=500, fy=500, cx=320, cy=240),
            rotation=[1, 0, 0, 0, 1, 0, 0, 0, 1], translation_m=[-0.1, 0, 0])
        cal = self.cb.stub.Calibrate(pb.CalibrateRequest(calibration_id="shared-rig",
                                                         parameters=params), timeout=30)
        get = pb.GetCalibrationRequest(calibration_id="shared-rig")
        self.assertEqual(self.ca.stub.GetCalibration(get, timeout=10), cal)
        self.ca.stub.DeleteCalibration(pb.DeleteCalibrationRequest(calibration_id="shared-rig"),
                                       timeout=10)
        self.assertEqual(self.cb.code_of(self.cb.stub.GetCalibration, get, timeout=10)[0],
                         CODE.NOT_FOUND)

    def test_racing_registrations_have_one_winner(self):
        ranges = {"a": 40.0, "b": 60.0}
        wins = collections.Counter()
        for round_no in range(10):
            cid = f"race-{round_no}"
            start = threading.Barrier(2)
            results = {}

            def register(name, client):
                request = register_request(cid, max_range_m=ranges[name])
                start.wait(30)
                results[name] = client.code_of(client.stub.RegisterContainer, request, timeout=60)

            threads = [threading.Thread(target=register, args=("a", self.ca)),
                       threading.Thread(target=register, args=("b", self.cb))]
            for t in threads:
                t.start()
            for t in threads:
                t.join(120)
            codes = sorted([results["a"][0], results["b"][0]], key=lambda c: c.value[0])
            self.assertEqual(codes, [CODE.OK, CODE.ALREADY_EXISTS], f"round {round_no}")
            winner = "a" if results["a"][0] == CODE.OK else "b"
            wins[winner] += 1
            # Both servers serve the winner's container, and only it.
            for client in (self.ca, self.cb):
                got = client.stub.GetContainer(pb.GetContainerRequest(container_id=cid), timeout=10)
                self.assertEqual(got.max_range_m, ranges[winner], f"round {round_no}")
                self.assertEqual(got, results[winner][1])
        print(f"\nrace winners: {dict(wins)}", file=sys.stderr)


@needs_own_server
class KillDuringRegister(unittest.TestCase):
    """SIGKILL during a registration leaves no entry or a complete one: at a random moment of
    the call, or while the entry file is being written (its hidden temp file exists)."""
    ROUNDS = 16

    def setUp(self):
        self.data_dir = tempfile.mkdtemp(prefix="soilvol-kill-")
        self.containers = os.path.join(self.data_dir, "containers")
        # Big enough that the entry file is over a megabyte.
        self.scan = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1, step=0.006))

    def tearDown(self):
        shutil.rmtree(self.data_dir, ignore_errors=True)

    def wait_for_temp_file(self, cid, future):
        """Polls until the server starts writing the entry (or the call ends)."""
        while not future.done():
            if any(n.startswith(f".{cid}.") for n in os.listdir(self.containers)):
                return True
            time.sleep(0.0005)
        return False

    def check_store(self, server, client, cid, client_code, present_ids):
        """Checks the store seen by a fresh server; returns whether `cid` is present."""
        code, container = client.code_of(client.stub.GetContainer,
                                         pb.GetContainerRequest(container_id=cid), timeout=10)
        self.assertIn(code, (CODE.OK, CODE.NOT_FOUND), f"{cid}: {code}")
        present = code == CODE.OK
        if client_code == CODE.OK:
            self.assertTrue(present, f"{cid}: the client was told OK but the entry is gone")
        self.assertEqual(server.rest("GET", f"/v1/containers/{cid}")[0], 200 if present else 404)
        if present:
            self.assertAlmostEqual(container.struck_capacity_m3, box_scene.STRUCK_M3,
                                   delta=0.02 * box_scene.STRUCK_M3)
            est = client.stub.EstimateVolume(pb.EstimateVolumeRequest(
                container_id=cid, scan=cloud(filled_box(0.25))), timeout=60)
            self.assertLess(volume_error(est.volume_m3, 0.25), MAX_ERROR_M3)
            present_ids.add(cid)
        listed = client.stub.ListContainers(pb.ListContainersRequest(), timeout=10)
        self.assertEqual(list(listed.unreadable), [], f"after {cid}")
        self.assertEqual({c.container_id for c in listed.containers}, present_ids)
        for name in os.listdir(self.containers):
            if not name.startswith("."):  # a killed writer may leave a hidden temp file
                self.assertTrue(name.endswith(".entry"), f"stray file {name}")
                self.assertIn(name[:-len(".entry")], present_ids, f"unlisted file {name}")
        return present

    def test_kill_during_register(self):
        server = Server(self.data_dir, args=["--workers", "1"]).start()
        client = Client(server)
        started = time.monotonic()
        client.stub.RegisterContainer(register_request("control", scan=self.scan), timeout=60)
        duration = time.monotonic() - started
        present_ids = {"control"}
        rng = random.Random(7)
        outcomes = collections.Counter()
        try:
            for round_no in range(self.ROUNDS):
                cid = f"kill-{round_no}"
                future = client.stub.RegisterContainer.future(
                    register_request(cid, scan=self.scan), timeout=60)
                if round_no % 2 == 0:  # anywhere from before the request arrives to its answer
                    time.sleep(rng.uniform(0.0, 1.6 * duration))
                    mode = "random"
                else:  # while the entry is written, fsynced and published
                    mode = "writing" if self.wait_for_temp_file(cid, future) else "late"
                    time.sleep(rng.uniform(0.0, 0.015))
                self.assertEqual(server.stop(signal.SIGKILL), -signal.SIGKILL)
                code = client.code_of(future.result)[0]
                self.assertIn(code, (CODE.OK, CODE.UNAVAILABLE), cid)
                client.close()
                server = Server(self.data_dir, args=["--workers", "1"]).start()
                client = Client(server)
                present = self.check_store(server, client, cid, code, present_ids)
                outcomes[(mode, "complete" if present else "absent")] += 1
        finally:
            client.close()
            server.stop()
        hidden = [n for n in os.listdir(self.containers) if n.startswith(".")]
        print(f"\nkills: {dict(outcomes)}; registration takes {duration * 1000:.0f} ms; "
              f"{len(hidden)} hidden temp files left", file=sys.stderr)


@needs_own_server
class GracefulShutdown(unittest.TestCase):
    """SIGTERM: calls already accepted finish (within the grace period), new ones are refused,
    the process exits 0."""

    def start_estimates(self, server, client, count):
        client.stub.RegisterContainer(register_request("slow-box"), timeout=60)
        # A small scan on 5 mm cells: over half a second each on one worker.
        request = pb.EstimateVolumeRequest(container_id="slow-box", scan=cloud(filled_box(0.2)),
                                           grid_cell_m=0.005)
        futures = [client.stub.EstimateVolume.future(request, timeout=60 * TIME_SCALE)
                   for _ in range(count)]
        # The gauges are set as calls are accepted: one running and the rest queued.
        accepted = wait_until(lambda: server_metric(server, "soilvol_in_flight") +
                              server_metric(server, "soilvol_queue_depth") >= count, 10, 0.01)
        self.assertTrue(accepted, "the server never held all the calls")
        return request, futures

    def test_in_flight_calls_finish(self):
        # Each call takes about 1 s here (15-20 s under the sanitizers): the grace covers three.
        grace_s = 20 * TIME_SCALE
        with Server(args=["--workers", "1", "--shutdown-grace-s", str(grace_s)]) as server:
            client = Client(server)
            request, futures = self.start_estimates(server, client, 3)
            sent = time.monotonic()
            server.proc.send_signal(signal.SIGTERM)
            self.assertTrue(wait_until(lambda: any("shutting down" in line for line in server.log),
                                       5, 0.01))
            # New calls are refused once the transport stops taking them, within moments of the
            # signal; one that raced in before that is served like the others.
            def unavailable(future):
                return (future.done() and future.exception() is not None and
                        future.exception().code() == CODE.UNAVAILABLE)

            late, refused = [], None
            until = time.monotonic() + 2.0
            while refused is None and time.monotonic() < until:
                time.sleep(0.05)
                late.append(client.stub.EstimateVolume.future(request, timeout=60))
                time.sleep(0.01)
                refused = next((f for f in late if unavailable(f)), None)
            for future in futures:
                self.assertLess(volume_error(future.result().volume_m3, 0.2), MAX_ERROR_M3)
            self.assertIsNotNone(refused, "no call was refused UNAVAILABLE within 2 s of SIGTERM")
            for future in late:  # served, refused as the server stops, or queue full
                if future.exception() is not None:
                    self.assertIn(future.exception().code(),
                                  (CODE.UNAVAILABLE, CODE.RESOURCE_EXHAUSTED))
            self.assertEqual(server.proc.wait(grace_s + 2), 0)
            self.assertLess(time.monotonic() - sent, grace_s)
            client.close()
        self.assertTrue(any(re.search(r"\bstopped\b.*drained=yes", line) for line in server.log),
                        "\n".join(server.log))

    def test_short_grace_does_not_hang(self):
        with Server(args=["--workers", "1", "--shutdown-grace-s", "0.1"]) as server:
            client = Client(server)
            _, futures = self.start_estimates(server, client, 4)
            sent = time.monotonic()
            server.proc.send_signal(signal.SIGTERM)
            codes = [client.code_of(f.result)[0] for f in futures]
            for code in codes:
                self.assertIn(code, (CODE.OK, CODE.UNAVAILABLE, CODE.CANCELLED), codes)
            # The queued calls cannot all have run: 4 x 0.5 s of work, 0.1 s of grace.
            self.assertIn(CODE.UNAVAILABLE, codes)
            self.assertEqual(server.proc.wait(10 * TIME_SCALE), 0)
            # The grace period plus the computation running when it ended.
            self.assertLess(time.monotonic() - sent, 5.0 * TIME_SCALE)
            client.close()
        self.assertTrue(any(re.search(r"\bstopped\b", line) for line in server.log))


if __name__ == "__main__":
    unittest.main(verbosity=2)
