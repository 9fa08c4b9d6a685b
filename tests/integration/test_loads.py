"""Truck loads end to end, against SQLite (the default) and PostgreSQL (the server ctest starts,
$SOILVOL_TEST_POSTGRES_URL; without it the PostgreSQL class is skipped, except under CI=true):
a load's life over gRPC, REST and the CLI - passes, running totals that equal the sum of the
records with the combined sigma computed here independently, the status against the target,
the body scan's reconciliation, the three ways a load closes - and the errors; WatchLoads over
gRPC, Server-Sent Events and the CLI: every change of a load's life in order, resumed after an
event id."""
import http.client
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import unittest
import uuid

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import (Server, load_grpc, needs_own_server, needs_postgres,
                     postgres_records_args, write_file)  # noqa: E402

grpc, pb, pb_grpc = load_grpc()

CODE = grpc.StatusCode
EMPTY = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))
IDLE_S = 4.0
CLI = os.environ.get("SOILVOL_CLI_BIN", "")



def fill_scan(fill_m, seed):
    return pb.Scan(cloud=pb.CloudScan(data=box_scene.encode_ply(box_scene.box_scan(fill_m, seed=seed))))


def sse_loads(stream, count):
    """The first `count` `load` events of a Server-Sent Events stream: (id, JSON) each."""
    events, event_id, event = [], None, None
    while len(events) < count:
        line = stream.readline().decode().rstrip("\n")
        if line.startswith("id: "):
            event_id = line[4:]
        elif line.startswith("event: "):
            event = line[7:]
        elif line.startswith("data: ") and event == "load":
            events.append((event_id, json.loads(line[6:])))
    return events


def combined_sigma(passes):
    """The passes' sum's 1-sigma: own errors in quadrature, each registration's shared part
    (the capacity sigma and the unobserved part, in quadrature) linearly."""
    independent, shared = 0.0, {}
    for p in passes:
        s = min(math.hypot(p.coverage.capacity_uncertainty_m3,
                           p.coverage.unobserved_uncertainty_m3), p.uncertainty_m3)
        independent += p.uncertainty_m3 ** 2 - s ** 2
        shared[p.registration_id] = shared.get(p.registration_id, 0.0) + s
    return math.sqrt(independent + sum(v * v for v in shared.values()))


class LoadsContract:
    """The tests; a subclass gives records_args()."""

    @classmethod
    def setUpClass(cls):
        cls.server = Server(args=["--workers", "2", "--load-idle-seconds", str(IDLE_S),
                                  *cls.records_args()]).start()
        cls.addClassCleanup(cls.server.close)  # also when the rest of the set-up fails
        cls.channel = cls.server.channel(grpc)
        cls.addClassCleanup(cls.channel.close)
        cls.stub = pb_grpc.SoilVolumeStub(cls.channel)
        cls.prefix = "ld-" + uuid.uuid4().hex[:8]
        cls.bucket, cls.body = cls.prefix + "-bucket", cls.prefix + "-body"
        for cid, targets in ((cls.bucket, None), (cls.body, pb.LoadTargets(volume_m3=0.30))):
            cls.stub.RegisterContainer(pb.RegisterContainerRequest(
                container_id=cid, scan=pb.Scan(cloud=pb.CloudScan(data=EMPTY)), overwrite=True,
                load_targets=targets, material=pb.Material(density_kg_m3=1600, bulking_factor=1.25),
                opening=pb.Opening(corners=[pb.Point3(x=x, y=y, z=z)
                                            for x, y, z in box_scene.opening_corners()])),
                timeout=60)

    def create(self, haul_unit, **load):
        return self.stub.CreateLoad(pb.CreateLoadRequest(
            load=pb.Load(haul_unit_id=haul_unit, **load)), timeout=30)

    def scan(self, cid, fill_m, load_id, seed=3, **extra):
        return self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id=cid, scan=fill_scan(fill_m, seed), load_id=load_id, omit_heightmap=True,
            **extra), timeout=60)

    def test_a_loads_life(self):
        truck = self.prefix + "-truck-1"
        load = self.create(truck, body_container_id=self.body, display_name="Truck 1")
        self.assertTrue(load.load_id.startswith("load-"))
        self.assertEqual(load.state, pb.LOAD_STATE_OPEN)
        self.assertEqual(load.pass_count, 0)
        self.assertEqual(load.assessment.status, pb.LOAD_STATUS_EMPTY)
        passes = []
        for i, fill in enumerate((0.10, 0.12, 0.09)):
            passes.append(self.scan(self.bucket, fill, load.load_id, seed=10 + i))
            self.assertEqual(passes[-1].load_role, pb.LOAD_ROLE_PASS)
            self.assertEqual(passes[-1].load_id, load.load_id)
            time.sleep(0.05)
        got = self.stub.GetLoad(pb.GetLoadRequest(load_id=load.load_id), timeout=30)
        self.assertEqual(got.pass_count, 3)
        self.assertEqual([p.estimate_id for p in got.passes], [p.estimate_id for p in passes])
        # The totals are the sum of the records, the sigma the passes' combined one.
        self.assertAlmostEqual(got.volume_m3, sum(p.volume_m3 for p in passes), places=12)
        self.assertAlmostEqual(got.uncertainty_m3, combined_sigma(passes), places=12)
        self.assertAlmostEqual(got.bank_volume_m3, got.volume_m3 / 1.25, places=9)
        self.assertAlmostEqual(got.mass_kg, got.volume_m3 * 1600, places=6)
        truth = box_scene.INNER_L * box_scene.INNER_W * (0.10 + 0.12 + 0.09)
        self.assertLess(abs(got.volume_m3 - truth), 3 * got.uncertainty_m3 + 0.002)
        self.assertGreater(got.mean_cycle_seconds, 0.0)
        # The body's target (0.30 m3, 5% bands) judges the total: 0.2976 m3 is in its band.
        self.assertEqual(got.assessment.status, pb.LOAD_STATUS_LOADED_OK)
        self.assertGreater(got.assessment.status_probability, 0.5)
        self.assertFalse(got.HasField("reconciliation"))

        closed = self.stub.CloseLoad(pb.CloseLoadRequest(load_id=load.load_id, etag=got.etag),
                                     timeout=30)
        self.assertEqual(closed.state, pb.LOAD_STATE_CLOSED)
        self.assertEqual(closed.close_reason, pb.LOAD_CLOSE_REASON_EXPLICIT)
        with self.assertRaises(grpc.RpcError) as refused:
            self.scan(self.bucket, 0.1, load.load_id)
        self.assertEqual(refused.exception.code(), CODE.FAILED_PRECONDITION)
        self.assertIn("load_id", refused.exception.details())
        # The body is scanned after the load closed: the passes reconcile with it.
        body = self.scan(self.body, 0.31, load.load_id, seed=21)
        self.assertEqual(body.load_role, pb.LOAD_ROLE_BODY_SCAN)
        got = self.stub.GetLoad(pb.GetLoadRequest(load_id=load.load_id), timeout=30)
        r = got.reconciliation
        self.assertEqual(r.estimate_id, body.estimate_id)
        self.assertAlmostEqual(r.difference_m3, body.volume_m3 - got.volume_m3, places=12)
        self.assertAlmostEqual(r.combined_uncertainty_m3,
                               math.hypot(got.uncertainty_m3, body.uncertainty_m3), places=12)
        self.assertTrue(r.within_two_sigma, r)
        self.assertEqual(got.pass_count, 3)  # a body scan is no pass

    def test_a_new_load_closes_the_haul_units_open_one_and_idle_loads_close(self):
        truck = self.prefix + "-truck-2"
        first = self.create(truck)
        self.scan(self.bucket, 0.1, first.load_id)
        second = self.create(truck)
        got = self.stub.GetLoad(pb.GetLoadRequest(load_id=first.load_id), timeout=30)
        self.assertEqual(got.close_reason, pb.LOAD_CLOSE_REASON_NEW_LOAD)
        self.assertEqual(got.pass_count, 1)
        listed = self.stub.ListLoads(pb.ListLoadsRequest(haul_unit_id=truck), timeout=30)
        self.assertEqual([l.load_id for l in listed.loads], [second.load_id, first.load_id])
        open_now = self.stub.ListLoads(pb.ListLoadsRequest(haul_unit_id=truck,
                                                           state=pb.LOAD_STATE_OPEN), timeout=30)
        self.assertEqual([l.load_id for l in open_now.loads], [second.load_id])
        # No pass for IDLE_S: closed, at its last activity plus the idle time.
        time.sleep(IDLE_S + 0.5)
        idle = self.stub.GetLoad(pb.GetLoadRequest(load_id=second.load_id), timeout=30)
        self.assertEqual(idle.state, pb.LOAD_STATE_CLOSED)
        self.assertEqual(idle.close_reason, pb.LOAD_CLOSE_REASON_IDLE)
        self.assertAlmostEqual(idle.close_time.ToMicroseconds() - idle.create_time.ToMicroseconds(),
                               IDLE_S * 1e6, delta=1000)
        with self.assertRaises(grpc.RpcError) as refused:
            self.scan(self.bucket, 0.1, second.load_id)
        self.assertEqual(refused.exception.code(), CODE.FAILED_PRECONDITION)
        self.assertIn("idle", refused.exception.details())
        self.assertEqual(list(self.stub.ListLoads(pb.ListLoadsRequest(
            haul_unit_id=truck, state=pb.LOAD_STATE_OPEN), timeout=30).loads), [])

    def open_sse(self, query, headers=None):
        sse = http.client.HTTPConnection("127.0.0.1", self.server.http_port, timeout=60)
        self.addCleanup(sse.close)
        sse.request("GET", "/v1/loads:watch?" + query, headers=headers or {})
        stream = sse.getresponse()
        self.assertEqual(stream.status, 200)
        self.assertEqual(stream.getheader("Content-Type"), "text/event-stream")
        return stream

    def test_watch_sees_every_change_of_a_loads_life_in_order_and_resumes(self):
        truck = self.prefix + "-truck-w"
        live = self.stub.WatchLoads(pb.WatchLoadsRequest(haul_unit_id=truck), timeout=60)
        stream = self.open_sse(f"haulUnitId={truck}")
        time.sleep(0.5)  # the feed places new watches at its next round
        first = self.create(truck, body_container_id=self.body)
        passes = [self.scan(self.bucket, 0.1, first.load_id, seed=31),
                  self.scan(self.bucket, 0.12, first.load_id, seed=32)]
        self.stub.CloseLoad(pb.CloseLoadRequest(load_id=first.load_id), timeout=30)
        body = self.scan(self.body, 0.22, first.load_id, seed=33)
        second = self.create(truck)
        third = self.create(truck)  # closes the second (NEW_LOAD)
        K = pb.LoadEventKind
        expected = [(K.LOAD_EVENT_KIND_CREATED, first.load_id),
                    (K.LOAD_EVENT_KIND_PASS_ADDED, first.load_id),
                    (K.LOAD_EVENT_KIND_PASS_ADDED, first.load_id),
                    (K.LOAD_EVENT_KIND_CLOSED, first.load_id),
                    (K.LOAD_EVENT_KIND_BODY_SCANNED, first.load_id),
                    (K.LOAD_EVENT_KIND_CREATED, second.load_id),
                    (K.LOAD_EVENT_KIND_CLOSED, second.load_id),
                    (K.LOAD_EVENT_KIND_CREATED, third.load_id),
                    (K.LOAD_EVENT_KIND_CLOSED, third.load_id)]  # idle: by the server's judge
        events = [next(live) for _ in expected]
        live.cancel()
        self.assertEqual([(e.kind, e.load.load_id) for e in events], expected)
        ids = [int(e.event_id) for e in events]
        self.assertEqual(ids, sorted(set(ids)))
        # Each event carries the load as it stood right after its change.
        self.assertEqual([e.load.pass_count for e in events], [0, 1, 2, 2, 2, 0, 0, 0, 0])
        self.assertEqual([e.estimate_id for e in events[1:3]], [p.estimate_id for p in passes])
        self.assertEqual([p.estimate_id for p in events[2].load.passes],
                         [p.estimate_id for p in passes])
        self.assertAlmostEqual(events[3].load.volume_m3, sum(p.volume_m3 for p in passes),
                               places=12)
        self.assertEqual(events[3].load.close_reason, pb.LOAD_CLOSE_REASON_EXPLICIT)
        self.assertFalse(events[3].load.HasField("reconciliation"))  # not yet scanned
        self.assertEqual(events[4].estimate_id, body.estimate_id)
        self.assertEqual(events[4].load.reconciliation.estimate_id, body.estimate_id)
        self.assertEqual(events[6].load.close_reason, pb.LOAD_CLOSE_REASON_NEW_LOAD)
        self.assertEqual(events[8].load.close_reason, pb.LOAD_CLOSE_REASON_IDLE)
        self.assertAlmostEqual(events[8].time.ToMicroseconds() - third.create_time.ToMicroseconds(),
                               IDLE_S * 1e6, delta=1000)
        self.assertEqual(events[8].load.etag, self.stub.GetLoad(
            pb.GetLoadRequest(load_id=third.load_id), timeout=30).etag)
        # The same events as Server-Sent Events, the event id the SSE id.
        sse = sse_loads(stream, len(events))
        self.assertEqual([i for i, _ in sse], [e.event_id for e in events])
        self.assertEqual([d["kind"] for _, d in sse], [K.Name(k) for k, _ in expected])
        self.assertEqual(sse[2][1]["load"]["passCount"], 2)

        # Resumed after an id: the rest, from the store, on both transports.
        resumed = self.stub.WatchLoads(pb.WatchLoadsRequest(
            haul_unit_id=truck, after_event_id=events[3].event_id), timeout=60)
        self.assertEqual([next(resumed).event_id for _ in events[4:]],
                         [e.event_id for e in events[4:]])
        resumed.cancel()
        again = sse_loads(self.open_sse(f"haulUnitId={truck}",
                                        {"Last-Event-ID": events[3].event_id}), 5)
        self.assertEqual([i for i, _ in again], [e.event_id for e in events[4:]])
        # Haul unit and container together: this truck's passes of the bucket only.
        of_bucket = self.stub.WatchLoads(pb.WatchLoadsRequest(
            haul_unit_id=truck, container_id=self.bucket, after_event_id=events[0].event_id),
            timeout=60)
        self.assertEqual([next(of_bucket).event_id for _ in range(2)],
                         [e.event_id for e in events[1:3]])
        of_bucket.cancel()
        if CLI:
            done = subprocess.run(
                [CLI, "--server", self.server.grpc_target, "loads", "watch", "--haul-unit", truck,
                 "--after", events[0].event_id, "--count", "3"],
                capture_output=True, text=True, timeout=60)
            self.assertEqual(done.returncode, 0, done.stderr)
            lines = done.stdout.splitlines()
            self.assertEqual([line.split()[0] for line in lines],
                             [e.event_id for e in events[1:4]])
            self.assertIn("pass_added", lines[0])
            self.assertIn("closed (explicit)", lines[2])

    def test_watch_refuses_bad_filters(self):
        for request, field in ((pb.WatchLoadsRequest(after_event_id="x"), "after_event_id"),
                               (pb.WatchLoadsRequest(haul_unit_id="a b"), "haul_unit_id"),
                               (pb.WatchLoadsRequest(container_id="../x"), "container_id")):
            with self.subTest(field=field):
                with self.assertRaises(grpc.RpcError) as error:
                    next(self.stub.WatchLoads(request, timeout=30))
                self.assertEqual(error.exception.code(), CODE.INVALID_ARGUMENT)
                self.assertTrue(error.exception.details().startswith(field),
                                error.exception.details())
        status, body = self.server.rest("GET", "/v1/loads:watch?afterEventId=-5")
        self.assertEqual(status, 400, body)

    def test_create_is_idempotent_by_request_id(self):
        truck = self.prefix + "-truck-3"
        request_id = str(uuid.uuid4())
        request = pb.CreateLoadRequest(load=pb.Load(haul_unit_id=truck), request_id=request_id)
        first = self.stub.CreateLoad(request, timeout=30)
        again = self.stub.CreateLoad(request, timeout=30)
        self.assertEqual(again.load_id, first.load_id)
        self.assertEqual(again.state, pb.LOAD_STATE_OPEN)  # the retry did not close it
        taken = pb.CreateLoadRequest(load_id=first.load_id, load=pb.Load(haul_unit_id=truck),
                                     request_id=str(uuid.uuid4()))
        with self.assertRaises(grpc.RpcError) as error:
            self.stub.CreateLoad(taken, timeout=30)
        self.assertEqual(error.exception.code(), CODE.ALREADY_EXISTS)

    def test_bad_requests_name_their_field(self):
        missing = self.prefix + "-nope"
        cases = [
            (self.stub.CreateLoad, pb.CreateLoadRequest(load=pb.Load()), CODE.INVALID_ARGUMENT,
             "load.haul_unit_id"),
            (self.stub.CreateLoad, pb.CreateLoadRequest(load=pb.Load(haul_unit_id="a b")),
             CODE.INVALID_ARGUMENT, "load.haul_unit_id"),
            (self.stub.CreateLoad, pb.CreateLoadRequest(
                load=pb.Load(haul_unit_id="t", body_container_id=missing)), CODE.NOT_FOUND,
             "load.body_container_id"),
            (self.stub.CreateLoad, pb.CreateLoadRequest(
                load=pb.Load(haul_unit_id="t", targets=pb.LoadTargets(volume_m3=-1))),
             CODE.INVALID_ARGUMENT, "load.load_targets.volume_m3"),
            (self.stub.CreateLoad, pb.CreateLoadRequest(load_id="../x", load=pb.Load(
                haul_unit_id="t")), CODE.INVALID_ARGUMENT, "load_id"),
            (self.stub.GetLoad, pb.GetLoadRequest(load_id=missing), CODE.NOT_FOUND, "load_id"),
            (self.stub.CloseLoad, pb.CloseLoadRequest(load_id=missing), CODE.NOT_FOUND, "load_id"),
            (self.stub.ListLoads, pb.ListLoadsRequest(page_token="zz"), CODE.INVALID_ARGUMENT,
             "page_token"),
            (self.stub.EstimateVolume, pb.EstimateVolumeRequest(
                container_id=self.bucket, scan=fill_scan(0.1, 1), load_id=missing),
             CODE.NOT_FOUND, "load_id"),
        ]
        for method, request, code, field in cases:
            with self.subTest(request=str(request)[:80]):
                with self.assertRaises(grpc.RpcError) as error:
                    method(request, timeout=60)
                self.assertEqual(error.exception.code(), code, error.exception.details())
                self.assertTrue(error.exception.details().startswith(field),
                                error.exception.details())
        load = self.create(self.prefix + "-truck-4")
        with self.assertRaises(grpc.RpcError) as error:
            self.scan(self.bucket, 0.1, load.load_id, skip_record=True)
        self.assertEqual(error.exception.code(), CODE.FAILED_PRECONDITION)
        with self.assertRaises(grpc.RpcError) as error:
            self.stub.CloseLoad(pb.CloseLoadRequest(load_id=load.load_id, etag="99"), timeout=30)
        self.assertEqual(error.exception.code(), CODE.ABORTED)

    def test_rest_routes(self):
        truck = self.prefix + "-truck-5"
        status, load = self.server.rest("POST", "/v1/loads", {
            "load": {"haulUnitId": truck, "bodyContainerId": self.body,
                     "targets": {"volumeM3": 0.2}, "labels": {"shift": "a"}}})
        self.assertEqual(status, 200, load)
        self.assertEqual(load["state"], "LOAD_STATE_OPEN")
        self.assertEqual(load["targets"]["volumeM3"], 0.2)
        self.scan(self.bucket, 0.12, load["loadId"])
        status, got = self.server.rest("GET", f"/v1/loads/{load['loadId']}")
        self.assertEqual(status, 200, got)
        self.assertEqual(got["passCount"], 1)
        self.assertEqual(got["labels"], {"shift": "a"})
        status, page = self.server.rest("GET", f"/v1/loads?haulUnitId={truck}&state=LOAD_STATE_OPEN")
        self.assertEqual(status, 200, page)
        self.assertEqual([l["loadId"] for l in page["loads"]], [load["loadId"]])
        status, closed = self.server.rest("POST", f"/v1/loads/{load['loadId']}:close", {})
        self.assertEqual(status, 200, closed)
        self.assertEqual(closed["closeReason"], "LOAD_CLOSE_REASON_EXPLICIT")
        status, error = self.server.rest("GET", "/v1/loads/no-such-load-here")
        self.assertEqual(status, 404, error)
        status, error = self.server.rest("POST", "/v1/loads", {"load": {}})
        self.assertEqual(status, 400, error)
        self.assertIn("load.haul_unit_id", error["message"])

    @unittest.skipUnless(CLI, "needs the soilvol CLI ($SOILVOL_CLI_BIN)")
    def test_cli(self):
        truck = self.prefix + "-truck-6"
        load_id = self.prefix + "-cli"
        cli = [CLI, "--server", self.server.grpc_target]

        def run(*args):
            done = subprocess.run(cli + list(args), capture_output=True, text=True, timeout=120)
            self.assertEqual(done.returncode, 0, done.stderr)
            return done.stdout

        out = run("loads", "create", "--haul-unit", truck, "--id", load_id, "--target-m3", "0.2")
        self.assertIn(load_id, out)
        with tempfile.TemporaryDirectory() as scratch:
            ply = write_file(scratch, "pass.ply",
                             box_scene.encode_ply(box_scene.box_scan(0.1, seed=5)))
            out = run("estimate", "--id", self.bucket, "--cloud", ply, "--load", load_id)
        self.assertIn(f"{load_id} (pass)", out)
        out = run("loads", "get", load_id)
        self.assertRegex(out, r"passes\s+1")
        out = run("loads", "list", "--haul-unit", truck)
        self.assertIn(load_id, out)
        out = run("loads", "close", load_id)
        self.assertIn("closed (explicit)", out)


@needs_own_server
class SqliteLoads(LoadsContract, unittest.TestCase):
    @classmethod
    def records_args(cls):
        return []


@needs_own_server
@needs_postgres
class PostgresLoads(LoadsContract, unittest.TestCase):
    records_args = staticmethod(postgres_records_args)


if __name__ == "__main__":
    unittest.main(verbosity=2)
