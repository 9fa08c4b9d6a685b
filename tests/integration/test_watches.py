"""Watch streams at a site's scale (issue 30): the limit is the --max-watches flag; a client
that leaves - an SSE reader closing its connection, a gRPC watch cancelled, a process killed -
frees its slot within 2 s (the server notices the hang-up on the socket and ends the watch at
its next heartbeat, --watch-heartbeat-seconds, 1 s by default), so screens that reconnect do not
lock each other out; the watches that stay keep getting every record."""
import json
import os
import socket
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import Server, load_grpc, needs_own_server, server_metric, wait_until  # noqa: E402
from test_records import SseReader  # noqa: E402

grpc, pb, pb_grpc = load_grpc()
LIMIT = 6
SLOT_FREED_S = 2.0


@needs_own_server
class WatchSlotsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = Server(args=["--max-watches", str(LIMIT)]).start()
        cls.channel = cls.server.channel(grpc)
        cls.stub = pb_grpc.SoilVolumeStub(cls.channel)
        cls.cid = "watch-slots"
        cls.stub.RegisterContainer(pb.RegisterContainerRequest(
            container_id=cls.cid, overwrite=True,
            scan=pb.Scan(cloud=pb.CloudScan(data=box_scene.encode_ply(box_scene.box_scan(0.0)))),
            opening=pb.Opening(corners=[pb.Point3(x=x, y=y, z=z)
                                        for x, y, z in box_scene.opening_corners()])),
            timeout=60)

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        cls.server.close()

    def watches(self, feed="estimates"):
        return server_metric(self.server, "soilvol_watches", feed=feed)

    def open_sse(self):
        return SseReader(self.server.http_port, f"/v1/estimates:watch?containerId={self.cid}")

    def seconds_until_watches(self, count):
        start = time.monotonic()
        self.assertTrue(wait_until(lambda: self.watches() == count, timeout_s=10.0, step_s=0.02),
                        f"{self.watches()} watches, not {count}")
        return time.monotonic() - start

    def test_each_feed_counts_its_own_watches(self):
        self.seconds_until_watches(0)
        loads = SseReader(self.server.http_port, "/v1/loads:watch")
        self.assertEqual(loads.status, 200)
        alerts = self.stub.WatchAlerts(pb.WatchAlertsRequest(), timeout=60)
        alerts.initial_metadata()
        counts = lambda: tuple(self.watches(feed) for feed in ("estimates", "alerts", "loads"))
        self.assertTrue(wait_until(lambda: counts() == (0, 1, 1), timeout_s=10.0, step_s=0.02),
                        counts())
        loads.close()
        alerts.cancel()
        self.assertTrue(wait_until(lambda: counts() == (0, 0, 0), timeout_s=10.0, step_s=0.02),
                        counts())

    def test_the_limit_is_the_flag_and_departed_clients_free_their_slots(self):
        self.seconds_until_watches(0)  # the other test's stream, closed a moment ago
        readers = [self.open_sse() for _ in range(LIMIT - 1)]
        self.assertEqual([r.status for r in readers], [200] * (LIMIT - 1))
        grpc_watch = self.stub.WatchEstimates(pb.WatchEstimatesRequest(container_id=self.cid),
                                              timeout=120)
        grpc_watch.initial_metadata()
        self.seconds_until_watches(LIMIT)
        # One more: refused over both transports, naming the limit.
        over = self.open_sse()
        self.assertEqual(over.status, 429)
        self.assertIn(f"at most {LIMIT} watches", over.response.read().decode())
        over.close()
        with self.assertRaises(grpc.RpcError) as ctx:
            next(self.stub.WatchEstimates(pb.WatchEstimatesRequest(container_id=self.cid),
                                          timeout=10))
        self.assertEqual(ctx.exception.code(), grpc.StatusCode.RESOURCE_EXHAUSTED)
        # The limit is one for every kind of watch: alerts and loads are refused too.
        for watch, request in ((self.stub.WatchAlerts, pb.WatchAlertsRequest()),
                               (self.stub.WatchLoads, pb.WatchLoadsRequest())):
            with self.assertRaises(grpc.RpcError) as ctx:
                next(watch(request, timeout=10))
            self.assertEqual(ctx.exception.code(), grpc.StatusCode.RESOURCE_EXHAUSTED)
        # Two browsers close their tabs, the gRPC client cancels: their slots come back.
        for reader in readers[:2]:
            reader.close()
        grpc_watch.cancel()
        freed = self.seconds_until_watches(LIMIT - 3)
        print(f"3 departed watches freed in {freed:.2f} s")
        self.assertLess(freed, SLOT_FREED_S)
        # A reader process killed outright (no orderly close by the client library).
        killed = subprocess.Popen(
            ["curl", "-sN", f"http://127.0.0.1:{self.server.http_port}"
             f"/v1/estimates:watch?containerId={self.cid}"], stdout=subprocess.DEVNULL)
        self.seconds_until_watches(LIMIT - 2)
        killed.kill()
        killed.wait()
        freed = self.seconds_until_watches(LIMIT - 3)
        print(f"a killed reader's watch freed in {freed:.2f} s")
        self.assertLess(freed, SLOT_FREED_S)
        # The readers that stayed get the next record; new readers fit again.
        again = [self.open_sse() for _ in range(3)]
        self.assertEqual([r.status for r in again], [200] * 3)
        answer = self.stub.EstimateVolume(pb.EstimateVolumeRequest(
            container_id=self.cid, omit_heightmap=True, scan=pb.Scan(cloud=pb.CloudScan(
                data=box_scene.encode_ply(box_scene.box_scan(0.2, seed=3))))), timeout=60)
        for reader in readers[2:] + again:
            event_id, name, data = reader.next_event()
            self.assertEqual((event_id, name), (answer.estimate_id, "estimate"))
            self.assertEqual(json.loads(data)["result"]["volumeM3"], answer.volume_m3)
            reader.close()
        self.seconds_until_watches(0)

    def test_an_idle_stream_gets_heartbeats_every_second(self):
        with socket.create_connection(("127.0.0.1", self.server.http_port), timeout=10) as sock:
            sock.sendall(f"GET /v1/estimates:watch?containerId={self.cid} HTTP/1.1\r\n"
                         "Host: x\r\nAccept: text/event-stream\r\n\r\n".encode())
            received = b""
            start = time.monotonic()
            # The stream's first lines hold one comment (": watching"); then three heartbeats.
            while received.count(b"\n:") < 4 and time.monotonic() - start < 10:
                received += sock.recv(4096)
            elapsed = time.monotonic() - start
        self.assertIn(b"200", received.split(b"\r\n", 1)[0])
        self.assertGreaterEqual(received.count(b"\n:"), 4, received)
        self.assertLess(elapsed, 4.5)  # three heartbeats at 1 s, and the poll's 0.25 s


class FlagsTest(unittest.TestCase):
    @needs_own_server
    def test_out_of_range_watch_flags_are_refused_naming_the_flag(self):
        for flag, value in (("--max-watches", "0"), ("--watch-heartbeat-seconds", "0.01"),
                            ("--watch-heartbeat-seconds", "61"),
                            ("--watch-coalesce-seconds", "2")):
            run = subprocess.run([os.environ["SOILVOL_SERVER_BIN"], flag, value],
                                 capture_output=True, text=True, timeout=30)
            self.assertEqual(run.returncode, 2, run.stderr)
            self.assertIn(flag.lstrip("-"), run.stderr)


if __name__ == "__main__":
    unittest.main()
