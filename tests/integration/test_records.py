"""Estimate records end to end: the same tests against SQLite (the default, in the data
directory) and PostgreSQL (the server ctest starts, $SOILVOL_TEST_POSTGRES_URL; without it the
PostgreSQL class is skipped, except under CI=true). Covers GetEstimate / ListEstimates over
gRPC and REST, paging, time filters, skip_record, two replicas sharing one database, and that
an answered estimate's record survives kill -9."""
import http.client
import json
import os
import signal
import struct
import sys
import threading
import time
import unittest
import urllib.request
import uuid

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import (Server, load_grpc, needs_own_server, needs_postgres,
                     postgres_records_args, postgres_url, server_metric)  # noqa: E402

grpc, pb, pb_grpc = load_grpc()
from google.protobuf import field_mask_pb2, timestamp_pb2  # noqa: E402

CODE = grpc.StatusCode
EMPTY = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))


def cloud(data):
    return pb.Scan(cloud=pb.CloudScan(data=data))



class SseReader:
    """A Server-Sent Events client on http.client: next_event() -> (id, event, data)."""

    def __init__(self, port, path, headers=None):
        self.conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        self.conn.request("GET", path, headers={"Accept": "text/event-stream", **(headers or {})})
        self.response = self.conn.getresponse()
        self.status = self.response.status
        self.content_type = self.response.getheader("Content-Type", "")

    def next_event(self):
        event_id, name, data = "", "message", []
        while True:
            line = self.response.readline().decode()
            if not line:
                raise EOFError("the stream ended")
            line = line.rstrip("\n")
            if not line:
                if data:
                    return event_id, name, "\n".join(data)
                continue
            if line.startswith(":"):
                continue
            field, _, value = line.partition(": ")
            if field == "id":
                event_id = value
            elif field == "event":
                name = value
            elif field == "data":
                data.append(value)

    def close(self):
        self.conn.close()


class RecordsContract:
    """The tests; a subclass gives records_args()."""

    @classmethod
    def setUpClass(cls):
        cls.data_dir = None
        cls.server = Server(args=["--workers", "2", *cls.records_args()]).start()
        cls.channel = cls.server.channel(grpc)
        cls.stub = pb_grpc.SoilVolumeStub(cls.channel)
        cls.prefix = "rec-" + uuid.uuid4().hex[:8]

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        cls.server.close()

    def register(self, cid, stub=None):
        return (stub or self.stub).RegisterContainer(pb.RegisterContainerRequest(
            container_id=cid, scan=cloud(EMPTY), overwrite=True,
            opening=pb.Opening(corners=[pb.Point3(x=x, y=y, z=z)
                                        for x, y, z in box_scene.opening_corners()])),
            timeout=60)

    def estimate(self, cid, fill, stub=None, **extra):
        scan = cloud(box_scene.encode_ply(box_scene.box_scan(fill, seed=3)))
        return (stub or self.stub).EstimateVolume(
            pb.EstimateVolumeRequest(container_id=cid, scan=scan, **extra), timeout=60)

    def test_every_estimate_is_kept_and_read_back(self):
        cid = self.prefix + "-a"
        self.register(cid)
        first = self.estimate(cid, 0.1, request_id="load-1")
        self.assertTrue(first.estimate_id)
        kept = self.stub.GetEstimate(pb.GetEstimateRequest(
            container_id=cid, estimate_id=first.estimate_id), timeout=30)
        self.assertEqual(kept.container_id, cid)
        self.assertEqual(kept.request_id, "load-1")
        self.assertEqual(kept.result, first)  # the answer as sent, heightmap included
        self.assertGreater(len(kept.result.heightmap.heights_f32le), 0)
        basic = self.stub.GetEstimate(pb.GetEstimateRequest(
            container_id=cid, estimate_id=first.estimate_id, view=pb.ESTIMATE_VIEW_BASIC),
            timeout=30)
        self.assertFalse(basic.result.HasField("heightmap"))
        self.assertEqual(basic.result.volume_m3, first.volume_m3)
        # omit_heightmap shortens the answer, not the record; skip_record keeps nothing.
        lean = self.estimate(cid, 0.2, omit_heightmap=True)
        self.assertFalse(lean.HasField("heightmap"))
        full = self.stub.GetEstimate(pb.GetEstimateRequest(
            container_id=cid, estimate_id=lean.estimate_id), timeout=30)
        self.assertGreater(len(full.result.heightmap.heights_f32le), 0)
        skipped = self.estimate(cid, 0.3, skip_record=True)
        self.assertEqual(skipped.estimate_id, "")
        listed = self.stub.ListEstimates(pb.ListEstimatesRequest(container_id=cid), timeout=30)
        self.assertEqual([e.estimate_id for e in listed.estimates],
                         [lean.estimate_id, first.estimate_id])  # newest first
        self.assertFalse(listed.estimates[0].result.HasField("heightmap"))  # BASIC by default
        # REST: the same resources.
        status, got = self.server.rest("GET", f"/v1/containers/{cid}/estimates/{first.estimate_id}")
        self.assertEqual(status, 200, got)
        self.assertEqual(got["estimateId"], first.estimate_id)
        self.assertEqual(got["result"]["volumeM3"], first.volume_m3)
        # The colour map, for embedding: a PNG of cols x rows cells of cellPx pixels.
        for query, px in (("", 12), ("?cellPx=3", 3)):
            url = (f"{self.server.base_url}/v1/containers/{cid}/estimates/{first.estimate_id}"
                   f"/heightmap.png{query}")
            with urllib.request.urlopen(url, timeout=30) as answer:
                self.assertEqual(answer.headers["Content-Type"], "image/png")
                png = answer.read()
            self.assertEqual(png[:8], b"\x89PNG\r\n\x1a\n")
            width, height = struct.unpack(">II", png[16:24])
            self.assertEqual((width, height), (first.heightmap.cols * px, first.heightmap.rows * px))
        for path, code in ((f"/v1/containers/{cid}/estimates/999999/heightmap.png", 404),
                           (f"/v1/containers/{cid}/estimates/x/heightmap.png", 400),
                           (f"/v1/containers/{cid}/estimates/{first.estimate_id}/heightmap.png?cellPx=0", 400)):
            status, body = self.server.rest("GET", path)
            self.assertEqual(status, code, (path, body))
        status, page = self.server.rest("GET", f"/v1/containers/{cid}/estimates?pageSize=1")
        self.assertEqual(status, 200, page)
        self.assertEqual(len(page["estimates"]), 1)
        status, rest = self.server.rest(
            "GET", f"/v1/containers/{cid}/estimates?pageSize=1&pageToken={page['nextPageToken']}")
        self.assertEqual([e["estimateId"] for e in rest["estimates"]], [first.estimate_id])
        self.assertEqual(rest.get("nextPageToken", ""), "")

    def test_lists_filter_by_time_and_span_containers(self):
        a, b = self.prefix + "-t1", self.prefix + "-t2"
        self.register(a)
        self.register(b)
        early = self.estimate(a, 0.1)
        time.sleep(0.05)
        middle = self.stub.GetEstimate(pb.GetEstimateRequest(
            container_id=a, estimate_id=early.estimate_id), timeout=30).create_time
        time.sleep(0.05)
        late = self.estimate(b, 0.1)
        since = self.stub.ListEstimates(pb.ListEstimatesRequest(
            container_id="-", start_time=timestamp_pb2.Timestamp(
                seconds=middle.seconds, nanos=middle.nanos + 1000)), timeout=30)
        ids = [e.estimate_id for e in since.estimates]
        self.assertIn(late.estimate_id, ids)
        self.assertNotIn(early.estimate_id, ids)
        until = self.stub.ListEstimates(pb.ListEstimatesRequest(
            container_id="-", end_time=timestamp_pb2.Timestamp(
                seconds=middle.seconds, nanos=middle.nanos + 1000)), timeout=30)
        ids = [e.estimate_id for e in until.estimates]
        self.assertIn(early.estimate_id, ids)
        self.assertNotIn(late.estimate_id, ids)
        # Paging every container, 1 per page, meets both in order.
        seen, token = [], ""
        while True:
            page = self.stub.ListEstimates(pb.ListEstimatesRequest(
                container_id="-", page_size=1, page_token=token), timeout=30)
            seen += [int(e.estimate_id) for e in page.estimates]
            token = page.next_page_token
            if not token:
                break
        self.assertEqual(seen, sorted(seen, reverse=True))
        self.assertTrue({int(early.estimate_id), int(late.estimate_id)} <= set(seen))

    def test_bad_requests_name_their_field(self):
        cases = [
            (pb.GetEstimateRequest(container_id="c", estimate_id="x1"), CODE.INVALID_ARGUMENT,
             "estimate_id"),
            (pb.GetEstimateRequest(container_id="c", estimate_id="-4"), CODE.INVALID_ARGUMENT,
             "estimate_id"),
            (pb.GetEstimateRequest(container_id="../c", estimate_id="1"), CODE.INVALID_ARGUMENT,
             "container_id"),
            (pb.GetEstimateRequest(container_id="c", estimate_id="999999999"), CODE.NOT_FOUND,
             "estimate_id"),
        ]
        for request, code, field in cases:
            with self.subTest(request=str(request)):
                with self.assertRaises(grpc.RpcError) as ctx:
                    self.stub.GetEstimate(request, timeout=30)
                self.assertEqual(ctx.exception.code(), code, ctx.exception.details())
                self.assertIn(field, ctx.exception.details())
        for request, field in [
                (pb.ListEstimatesRequest(container_id="-", page_token="bm9wZQ"), "page_token"),
                (pb.ListEstimatesRequest(container_id="-", page_size=-1), "page_size"),
                (pb.ListEstimatesRequest(container_id="-", start_time=timestamp_pb2.Timestamp(
                    seconds=100), end_time=timestamp_pb2.Timestamp(seconds=50)), "end_time")]:
            with self.assertRaises(grpc.RpcError) as ctx:
                self.stub.ListEstimates(request, timeout=30)
            self.assertEqual(ctx.exception.code(), CODE.INVALID_ARGUMENT)
            self.assertIn(field, ctx.exception.details())
        status, body = self.server.rest("GET", "/v1/containers/c/estimates/abc")
        self.assertEqual(status, 400, body)

    def test_history_is_the_current_registration_and_deleting_keeps_or_purges_records(self):
        cid, gone = self.prefix + "-reg", self.prefix + "-purge"
        first = self.register(cid)
        self.assertTrue(first.registration_id)
        early = self.estimate(cid, 0.1, omit_heightmap=True)
        self.assertEqual(early.registration_id, first.registration_id)
        # Renaming keeps the registration; registering again makes a new one.
        renamed = self.stub.UpdateContainer(pb.UpdateContainerRequest(
            container=pb.Container(container_id=cid, display_name="Bucket 7"),
            update_mask=field_mask_pb2.FieldMask(paths=["display_name"])), timeout=30)
        self.assertEqual(renamed.registration_id, first.registration_id)
        second = self.register(cid)
        self.assertNotEqual(second.registration_id, first.registration_id)
        late = self.estimate(cid, 0.2, omit_heightmap=True)
        self.assertEqual(late.registration_id, second.registration_id)

        def listed(container, registration=None, transport="grpc"):
            if transport == "rest":
                query = "" if registration is None else f"?registrationId={registration}"
                status, body = self.server.rest(
                    "GET", f"/v1/containers/{container}/estimates{query}")
                self.assertEqual(status, 200, body)
                return [e["estimateId"] for e in body.get("estimates", [])]
            request = pb.ListEstimatesRequest(container_id=container,
                                              registration_id=registration or "")
            return [e.estimate_id for e in self.stub.ListEstimates(request, timeout=30).estimates]

        for transport in ("grpc", "rest"):
            self.assertEqual(listed(cid, transport=transport), [late.estimate_id])
            self.assertEqual(listed(cid, "-", transport), [late.estimate_id, early.estimate_id])
            self.assertEqual(listed(cid, first.registration_id, transport), [early.estimate_id])
        with self.assertRaises(grpc.RpcError) as ctx:
            listed(cid, "../x")
        self.assertEqual(ctx.exception.code(), CODE.INVALID_ARGUMENT)
        self.assertIn("registration_id", ctx.exception.details())
        # Deleted, the records stay by default, every registration's.
        self.stub.DeleteContainer(pb.DeleteContainerRequest(container_id=cid), timeout=30)
        self.assertEqual(listed(cid), [late.estimate_id, early.estimate_id])
        # Purged: none left, over REST; another container's records are untouched.
        self.register(gone)
        purged = self.estimate(gone, 0.1, omit_heightmap=True)
        status, body = self.server.rest("DELETE", f"/v1/containers/{gone}?purgeRecords=true")
        self.assertEqual(status, 200, body)
        self.assertEqual(listed(gone), [])
        with self.assertRaises(grpc.RpcError) as ctx:
            self.stub.GetEstimate(pb.GetEstimateRequest(container_id=gone,
                                                        estimate_id=purged.estimate_id),
                                  timeout=30)
        self.assertEqual(ctx.exception.code(), CODE.NOT_FOUND)
        self.assertEqual(listed(cid), [late.estimate_id, early.estimate_id])
        # A purge of a container already deleted purges what is left, and says NOT_FOUND.
        status, body = self.server.rest("DELETE", f"/v1/containers/{cid}?purgeRecords=true")
        self.assertEqual(status, 404, body)
        self.assertEqual(listed(cid), [])

    def test_a_second_replica_reads_what_the_first_recorded(self):
        cid = self.prefix + "-r"
        self.register(cid)
        with self.replica() as other:
            channel = other.channel(grpc)
            stub = pb_grpc.SoilVolumeStub(channel)
            written = self.estimate(cid, 0.15)
            got = stub.GetEstimate(pb.GetEstimateRequest(
                container_id=cid, estimate_id=written.estimate_id), timeout=30)
            self.assertEqual(got.result.volume_m3, written.volume_m3)
            channel.close()

    def test_watch_delivers_within_a_second_and_resumes_over_sse_on_another_replica(self):
        cid = self.prefix + "-w"
        self.register(cid)
        watch = self.stub.WatchEstimates(pb.WatchEstimatesRequest(container_id=cid), timeout=120)
        watch.initial_metadata()  # the watch is on
        first = self.estimate(cid, 0.1, omit_heightmap=True)
        answered = time.monotonic()
        got = next(watch)
        self.assertLess(time.monotonic() - answered, 1.0)
        self.assertEqual(got.estimate_id, first.estimate_id)
        self.assertEqual(got.result.volume_m3, first.volume_m3)
        self.assertFalse(got.result.HasField("heightmap"))  # BASIC by default
        watch.cancel()
        missed = [self.estimate(cid, 0.1, omit_heightmap=True).estimate_id for _ in range(3)]
        with self.replica() as other:
            events = SseReader(other.http_port, f"/v1/estimates:watch?containerId={cid}",
                               {"Last-Event-ID": first.estimate_id})
            self.assertEqual(events.status, 200)
            self.assertTrue(events.content_type.startswith("text/event-stream"))
            # The resume: everything after the last id seen, in order.
            self.assertEqual([events.next_event()[0] for _ in missed], missed)
            # Live, written by the first replica: seen through the shared records.
            live = self.estimate(cid, 0.1, omit_heightmap=True)
            answered = time.monotonic()
            event_id, name, data = events.next_event()
            self.assertLess(time.monotonic() - answered, 1.0)
            self.assertEqual((event_id, name), (live.estimate_id, "estimate"))
            self.assertEqual(json.loads(data)["result"]["volumeM3"], live.volume_m3)
            events.close()
            # "0": from the first record kept.
            everything = SseReader(
                other.http_port, f"/v1/estimates:watch?containerId={cid}&afterEstimateId=0")
            self.assertEqual([everything.next_event()[0] for _ in range(5)],
                             [first.estimate_id] + missed + [live.estimate_id])
            everything.close()
            # Bad requests are plain HTTP errors, before any stream.
            bad = SseReader(other.http_port, "/v1/estimates:watch?afterEstimateId=x")
            self.assertEqual(bad.status, 400)
            bad.close()
            unknown = SseReader(other.http_port, "/v1/estimates:watch?containerId=nobody-here")
            self.assertEqual(unknown.status, 404)
            unknown.close()
        # The same over gRPC: a watch of a container that does not exist ends at once.
        with self.assertRaises(grpc.RpcError) as ctx:
            next(self.stub.WatchEstimates(
                pb.WatchEstimatesRequest(container_id="nobody-here"), timeout=10))
        self.assertEqual(ctx.exception.code(), CODE.NOT_FOUND, ctx.exception.details())

    def test_metrics_count_the_records_and_the_watches(self):
        store = self.store_kind()
        figures = lambda: {name: server_metric(self.server, name, **labels) for name, labels in (
            ("soilvol_records_written_total", {"store": store}),
            ("soilvol_record_batches_total", {"store": store}),
            ("soilvol_record_failures_total", {"store": store}),
            ("soilvol_records_queued", {}),
            ("soilvol_watches", {"feed": "estimates"}))}
        before = figures()
        cid = self.prefix + "-m"
        self.register(cid)
        answers = [self.estimate(cid, fill, omit_heightmap=True) for fill in (0.1, 0.2)]
        answers.append(self.estimate(cid, 0.2, skip_record=True))
        events = SseReader(self.server.http_port, f"/v1/estimates:watch?containerId={cid}")
        self.assertEqual(events.status, 200)
        after = figures()
        # Other tests of this class may record meanwhile only when run in parallel; they are not.
        self.assertEqual(after["soilvol_records_written_total"],
                         before["soilvol_records_written_total"] + 2)
        self.assertGreaterEqual(after["soilvol_record_batches_total"],
                                before["soilvol_record_batches_total"] + 1)
        self.assertEqual(after["soilvol_record_failures_total"],
                         before["soilvol_record_failures_total"])
        self.assertEqual(after["soilvol_records_queued"], 0)  # each answer waited for its commit
        self.assertEqual(after["soilvol_watches"], before["soilvol_watches"] + 1)
        events.close()
        # The business figures count every answered estimate, recorded or not, per container.
        self.assertEqual(server_metric(self.server, "soilvol_estimates_total", container=cid),
                         len(answers))
        self.assertAlmostEqual(
            server_metric(self.server, "soilvol_estimated_volume_cubic_meters_total",
                          container=cid),
            sum(max(a.volume_m3, 0.0) for a in answers), places=9)
        self.assertAlmostEqual(
            server_metric(self.server, "soilvol_estimated_bank_volume_cubic_meters_total",
                          container=cid),
            sum(max(a.load.bank_volume_m3, 0.0) for a in answers), places=9)
        # The process's own figures, as every Prometheus client library names them.
        for name in ("process_cpu_seconds_total", "process_resident_memory_bytes",
                     "process_open_fds", "process_max_fds", "process_start_time_seconds"):
            self.assertGreater(server_metric(self.server, name), 0, name)
        self.assertLess(abs(server_metric(self.server, "process_start_time_seconds")
                            - time.time()), 3600)

    def test_answered_estimates_survive_kill_9(self):
        cid = self.prefix + "-k"
        self.register(cid)
        answered = []
        victim = self.replica().start()
        channel = victim.channel(grpc)
        stub = pb_grpc.SoilVolumeStub(channel)
        stop = threading.Event()

        def load():
            while not stop.is_set():
                try:
                    answered.append(self.estimate(cid, 0.1, stub=stub, omit_heightmap=True)
                                    .estimate_id)
                except grpc.RpcError:
                    return  # the server died under this call: no answer, no promise

        threads = [threading.Thread(target=load) for _ in range(4)]
        for t in threads:
            t.start()
        deadline = time.time() + 60
        while len(answered) < 12 and time.time() < deadline:
            time.sleep(0.01)
        victim.proc.send_signal(signal.SIGKILL)
        stop.set()
        for t in threads:
            t.join(60)
        channel.close()
        victim.stop()
        self.assertGreaterEqual(len(answered), 12)
        # Every answered id is there for the server that shares the records.
        for estimate_id in answered:
            got = self.stub.GetEstimate(pb.GetEstimateRequest(
                container_id=cid, estimate_id=estimate_id, view=pb.ESTIMATE_VIEW_BASIC),
                timeout=30)
            self.assertEqual(got.estimate_id, estimate_id)


@needs_own_server
class SqliteRecords(RecordsContract, unittest.TestCase):
    @classmethod
    def records_args(cls):
        return []  # the default: <data-dir>/records.sqlite3

    @staticmethod
    def store_kind():
        return "sqlite"

    def replica(self):
        """Another process on the same data directory (and so the same SQLite file)."""
        return Server(data_dir=self.server.data_dir, args=["--workers", "2"])


@needs_own_server
@needs_postgres
class PostgresRecords(RecordsContract, unittest.TestCase):
    records_args = staticmethod(postgres_records_args)

    @staticmethod
    def store_kind():
        return "postgresql"

    def replica(self):
        """Another process on the same model directory (as Kubernetes replicas share a volume)
        and the same PostgreSQL database."""
        return Server(data_dir=self.server.data_dir,
                      args=["--workers", "2", "--records-url", postgres_url()])


if __name__ == "__main__":
    unittest.main(verbosity=2)
