"""Issue 12's attacks on a running server, replayed: each gets a clear 4xx at a bounded cost
(time and the server's peak resident memory), and the server keeps serving normal calls."""
import gzip
import http.client
import json
import os
import signal
import socket
import statistics
import struct
import sys
import threading
import time
import unittest
import zlib

from box_scene import box_scan, encode_ply, opening_corners
from harness import (TIME_SCALE, Server, b64, cloud_scan, corners_json, load_grpc,
                     needs_own_server, server_metric, shared_server, wait_until)

OPENCV_DATA = "/usr/share/doc/opencv-doc/examples/data"
HAVE_CHESSBOARDS = os.path.exists(f"{OPENCV_DATA}/left01.jpg")


def peak_rss_mb(server):
    """The server process's peak resident set (VmHWM) [MiB]."""
    with open(f"/proc/{server.proc.pid}/status") as status:
        for line in status:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmHWM")


def rss_growth_mb(server, baseline_mb):
    """How far the server's peak resident set rose above `baseline_mb` [MiB]: a body that was
    buffered whole shows here in any build (a sanitizer's shadow memory lifts the baseline, not
    the growth)."""
    return peak_rss_mb(server) - baseline_mb


def png_claiming(width, height, bit_depth=16):
    """A PNG signature and a valid IHDR declaring `width` x `height` grey, then a tiny IDAT."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) +
            chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b""))


def at_once(call, count):
    """Runs `call` on `count` threads at once; the seconds until the last one returned."""
    threads = [threading.Thread(target=call) for _ in range(count)]
    start = time.monotonic()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return time.monotonic() - start


def cpu_seconds(server):
    """CPU time the server process has used so far (user + system) [s]."""
    with open(f"/proc/{server.proc.pid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def chessboard_pairs(count):
    """`count` pairs of opencv-doc's real 9x6 chessboard images (its 13 pairs, repeated)."""
    numbers = [n for n in range(1, 15) if n != 10]
    pairs = []
    for i in range(count):
        n = numbers[i % len(numbers)]
        with open(f"{OPENCV_DATA}/left{n:02d}.jpg", "rb") as left, \
                open(f"{OPENCV_DATA}/right{n:02d}.jpg", "rb") as right:
            pairs.append((left.read(), right.read()))
    return pairs


def calibration_json(calibration_id, pairs):
    return {"calibrationId": calibration_id, "overwrite": True,
            "chessboard": {"pairs": [{"left": b64(l), "right": b64(r)} for l, r in pairs],
                           "innerCorners": {"cols": 9, "rows": 6}, "squareSizeM": 0.025}}


def stops_working(server, settle_s=1.0, window_s=1.0):
    """CPU seconds the server spends in `window_s`, measured `settle_s` after now."""
    time.sleep(settle_s)
    before = cpu_seconds(server)
    time.sleep(window_s)
    return cpu_seconds(server) - before


def webp_claiming(width, height):
    """A lossless WebP (VP8L) header declaring `width` x `height` (14-bit fields, minus one)."""
    bits = (width - 1) | ((height - 1) << 14)
    vp8l = b"\x2f" + struct.pack("<I", bits) + b"\0" * 32
    body = b"WEBP" + b"VP8L" + struct.pack("<I", len(vp8l)) + vp8l
    return b"RIFF" + struct.pack("<I", len(body)) + body


def compressed_pcd_claiming(points, extra_floats):
    """A binary_compressed PCD whose sizes agree with its header and with LZF's ratio, but whose
    body would expand to points x (12 + 4 extra_floats) bytes."""
    header = (f"FIELDS x y z pad\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 {extra_floats}\n"
              f"WIDTH {points}\nHEIGHT 1\nDATA binary_compressed\n").encode()
    uncompressed = points * (12 + 4 * extra_floats)
    compressed = uncompressed // 50
    return header + struct.pack("<II", compressed, uncompressed) + b"\x1f" * compressed


class Hostile(unittest.TestCase):
    """Cases that any server answers the same way, shared or not."""

    @classmethod
    def setUpClass(cls):
        cls.server = shared_server()

    @classmethod
    def tearDownClass(cls):
        cls.server.close()

    def test_kilometre_opening_is_refused_by_its_corners(self):
        scan = cloud_scan(encode_ply(box_scan()))
        for side in (3000.0, 1000.0, 31.0):
            corners = [(0.0, 0.0, 2.0), (side, 0.0, 2.0), (side, side, 2.0), (0.0, side, 2.0)]
            start = time.monotonic()
            status, err = self.server.rest("POST", "/v1/containers",
                                           {"containerId": "huge", "overwrite": True,
                                            "scan": scan, "opening": corners_json(corners)})
            self.assertEqual(status, 400, err)
            self.assertIn("opening.corners", err["message"])
            self.assertLess(time.monotonic() - start, 2.0 * TIME_SCALE)
        self.assertEqual(self.server.rest("GET", "/v1/containers/huge")[0], 404)

    def test_images_of_unchecked_formats_or_past_the_budget_are_not_decoded(self):
        cases = {
            "webp": webp_claiming(16383, 16383),
            "jp2": b"\0\0\0\x0cjP  \r\n\x87\n" + b"\0" * 1000,
            "png16": png_claiming(8192, 8192),
        }
        for name, image in cases.items():
            pairs = [{"left": b64(image), "right": b64(image)}] * 6
            start = time.monotonic()
            status, err = self.server.rest(
                "POST", "/v1/calibrations",
                {"calibrationId": f"bomb-{name}", "overwrite": True,
                 "chessboard": {"pairs": pairs, "innerCorners": {"cols": 9, "rows": 6},
                                "squareSizeM": 0.025}})
            self.assertEqual(status, 400, (name, err))
            self.assertRegex(err["message"], "not a decodable image|pixels an image may hold|pixels in all",
                             name)
            self.assertLess(time.monotonic() - start, 2.0 * TIME_SCALE, name)

    def test_calibration_work_is_bounded_before_decoding(self):
        image = b64(png_claiming(640, 480, bit_depth=8))
        status, err = self.server.rest(
            "POST", "/v1/calibrations",
            {"calibrationId": "many", "overwrite": True,
             "chessboard": {"pairs": [{"left": image, "right": image}] * 201,
                            "innerCorners": {"cols": 9, "rows": 6}, "squareSizeM": 0.025}})
        self.assertEqual(status, 400, err)
        self.assertIn("at most 200 pairs", err["message"])

    def test_unrouted_paths_share_one_metrics_label(self):
        before = len(self.server.rest("GET", "/metrics")[1])
        for i in range(500):
            status, _ = self.server.rest("GET", f"/no/such/path/{i}")
            self.assertEqual(status, 404)
        text = self.server.rest("GET", "/metrics")[1]
        self.assertNotIn("/no/such/path", text)
        self.assertLess(len(text), before + 4096)

    def test_http_status_and_json_code_agree(self):
        for path, status, code in (("/no/such/path", 404, 5), ("/v1/containers/%zz", 400, 3)):
            got, err = self.server.rest("GET", path)
            self.assertEqual((got, err["code"]), (status, code), (path, err))

    def test_huge_grpc_timeout_is_no_deadline(self):
        status, body = self.server.rest("GET", "/v1/containers",
                                        headers={"Grpc-Timeout": "99999999H"})
        self.assertEqual(status, 200, body)

    def test_text_plain_bodies_are_refused(self):
        status, err = self.server.rest("POST", "/v1/containers", raw=b'{"containerId": "plain"}',
                                       headers={"Content-Type": "text/plain"})
        self.assertEqual(status, 415, err)
        self.assertEqual(self.server.rest("GET", "/v1/containers/plain")[0], 404)


@needs_own_server
class HostileOwnServer(unittest.TestCase):
    """Cases that read the server's memory or need flags of their own."""

    def test_chunked_body_past_the_limit_is_stopped_as_it_arrives(self):
        with Server(args=["--workers", "1", "--max-message-mb", "1"]) as server:
            baseline = peak_rss_mb(server)
            conn = http.client.HTTPConnection("127.0.0.1", server.http_port, timeout=30)
            conn.putrequest("POST", "/v1/containers")
            conn.putheader("Content-Type", "application/json")
            conn.putheader("Transfer-Encoding", "chunked")
            conn.endheaders()
            chunk = b"x" * (1 << 20)
            sent = 0
            try:
                for _ in range(200):  # 200 MiB offered
                    conn.send(b"%x\r\n" % len(chunk) + chunk + b"\r\n")
                    sent += 1
                conn.send(b"0\r\n\r\n")
                status = conn.getresponse().status
            except (BrokenPipeError, ConnectionResetError, http.client.HTTPException):
                status = None  # the server stopped reading: the refusal may not be readable
            conn.close()
            self.assertIn(status, (None, 413))
            self.assertLess(sent, 200 if status is None else 201)
            self.assertLess(rss_growth_mb(server, baseline), 100.0)  # 200 MiB offered
            self.assertEqual(server.rest("GET", "/v1/containers")[0], 200)

    def test_gzip_body_is_counted_inflated(self):
        with Server(args=["--workers", "1", "--max-message-mb", "1"]) as server:
            baseline = peak_rss_mb(server)
            bomb = gzip.compress(b"[" + b" " * (100 << 20) + b"]", compresslevel=9)
            status, err = server.rest("POST", "/v1/containers", raw=bomb,
                                      headers={"Content-Encoding": "gzip"})
            self.assertIn(status, (413, 415), err)
            self.assertLess(rss_growth_mb(server, baseline), 60.0)  # 100 MiB inflated
            self.assertEqual(server.rest("GET", "/v1/containers")[0], 200)

    def test_compressed_pcd_with_consistent_huge_sizes_is_refused_before_allocating(self):
        with Server(args=["--workers", "1", "--max-message-mb", "16"]) as server:
            baseline = peak_rss_mb(server)
            pcd = compressed_pcd_claiming(4_500_000, 16)  # 342 MB inflated, 6.8 MB sent
            status, err = server.rest("POST", "/v1/containers",
                                      {"containerId": "pcd", "scan": {"cloud": {"data": b64(pcd)}},
                                       "opening": corners_json(opening_corners())})
            self.assertEqual(status, 400, err)
            self.assertIn("a scan may expand to", err["message"])
            self.assertLess(rss_growth_mb(server, baseline), 200.0)  # 342 MB if allocated

    def test_disallowed_origin_is_refused_before_it_runs(self):
        with Server(args=["--workers", "1", "--cors-origin", "https://ok.example"]) as server:
            body = b'{"containerId": "evil", "scan": {}}'
            for content_type in ("text/plain", "application/json"):
                status, err = server.rest("POST", "/v1/containers", raw=body,
                                          headers={"Origin": "https://evil.example",
                                                   "Content-Type": content_type})
                self.assertEqual(status, 403, err)
            self.assertEqual(server.rest("GET", "/v1/containers/evil")[0], 404)
            status, _ = server.rest("GET", "/v1/containers", headers={"Origin": "https://ok.example"})
            self.assertEqual(status, 200)
            # A page the server serves itself is same-origin, whatever --cors-origin says.
            own = f"http://127.0.0.1:{server.http_port}"
            status, _ = server.rest("GET", "/v1/containers", headers={"Origin": own})
            self.assertEqual(status, 200)


@needs_own_server
@unittest.skipIf(TIME_SCALE > 1, "sanitizers multiply memory: peak RSS is measured in Release")
class MemoryBudget(unittest.TestCase):
    """The largest requests the documented limits allow, measured in the server's peak RSS: one
    under 1.5 GB, and 8 at once (2 workers, 8 waiting: the Deployment's pod) under its 2 GiB
    memory limit. Scans of 5M points (the cloud limit; 60 MB as binary PLY, under 64 MiB)."""

    LIMIT_POD_MB = 2048.0
    LIMIT_ONE_MB = 1536.0

    def test_largest_scans_alone_and_eight_at_once(self):
        grpc, pb, pb_grpc = load_grpc()
        # Spacing for ~5M returns over the box and its surroundings.
        big = encode_ply(box_scan(0.2, step=0.00101, seed=3))
        self.assertLess(len(big), 64 << 20)
        with Server(args=["--workers", "2", "--max-queue", "8"]) as server:
            with server.channel(grpc) as channel:
                stub = pb_grpc.SoilVolumeStub(channel)
                register = pb.RegisterContainerRequest(container_id="box")
                register.scan.cloud.data = encode_ply(box_scan())
                for x, y, z in opening_corners():
                    register.opening.corners.add(x=x, y=y, z=z)
                stub.RegisterContainer(register, timeout=120)
                request = pb.EstimateVolumeRequest(container_id="box")
                request.scan.cloud.data = big
                baseline = peak_rss_mb(server)
                start = time.monotonic()
                one = stub.EstimateVolume(request, timeout=600)
                alone_s = time.monotonic() - start
                alone_mb = peak_rss_mb(server)
                codes = []

                def estimate():
                    try:
                        stub.EstimateVolume(request, timeout=600)
                        codes.append("OK")
                    except grpc.RpcError as e:
                        codes.append(e.code().name)

                eight_s = at_once(estimate, 8)
                eight_mb = peak_rss_mb(server)
        print(f"\nmemory (gRPC): idle {baseline:.0f} MiB; one 5M-point estimate {alone_mb:.0f} MiB "
              f"peak ({alone_s:.1f} s, {one.volume_m3 * 1e3:.0f} L); 8 at once {eight_mb:.0f} MiB "
              f"peak ({eight_s:.1f} s, {codes})", file=sys.stderr)
        self.assertLess(alone_mb, self.LIMIT_ONE_MB)
        self.assertLess(eight_mb, self.LIMIT_POD_MB)
        self.assertTrue(all(code in ("OK", "RESOURCE_EXHAUSTED") for code in codes), codes)
        self.eight_over_rest(big)

    def eight_over_rest(self, big):
        """The same 8 as base64 JSON bodies of 79 MB each."""
        with Server(args=["--workers", "2", "--max-queue", "8"]) as server:
            status, err = server.rest("POST", "/v1/containers",
                                      {"containerId": "box", "scan": cloud_scan(encode_ply(box_scan())),
                                       "opening": corners_json(opening_corners())})
            self.assertEqual(status, 200, err)
            body = json.dumps({"scan": cloud_scan(big)}).encode()
            statuses = []

            def estimate():
                conn = http.client.HTTPConnection("127.0.0.1", server.http_port, timeout=600)
                conn.request("POST", "/v1/containers/box:estimate", body=body,
                             headers={"Content-Type": "application/json"})
                response = conn.getresponse()
                response.read()
                statuses.append(response.status)
                conn.close()

            took_s = at_once(estimate, 8)
            peak = peak_rss_mb(server)
        print(f"memory (REST): 8 bodies of {len(body) / 1e6:.0f} MB at once {peak:.0f} MiB peak "
              f"({took_s:.1f} s, {statuses})", file=sys.stderr)
        self.assertLess(peak, self.LIMIT_POD_MB)
        self.assertTrue(all(status in (200, 429) for status in statuses), statuses)


@needs_own_server
class SlowClients(unittest.TestCase):
    """#5: 200 connections sending a byte a second do not hold anyone else up."""

    def test_slowloris_does_not_delay_normal_calls(self):
        with Server(args=["--workers", "2"]) as server:
            scan = cloud_scan(encode_ply(box_scan()))
            status, err = server.rest("POST", "/v1/containers",
                                      {"containerId": "box", "scan": scan,
                                       "opening": corners_json(opening_corners())})
            self.assertEqual(status, 200, err)

            def timed_calls(count):
                times = []
                for _ in range(count):
                    start = time.monotonic()
                    self.assertEqual(server.rest("GET", "/v1/containers")[0], 200)
                    self.assertEqual(server.rest("POST", "/v1/containers/box:estimate",
                                                 {"scan": scan})[0], 200)
                    times.append(time.monotonic() - start)
                return times

            baseline = timed_calls(10)
            slow = []
            for _ in range(200):
                conn = socket.create_connection(("127.0.0.1", server.http_port), timeout=30)
                conn.sendall(b"POST /v1/containers HTTP/1.1\r\n")
                slow.append(conn)
            stop = threading.Event()
            closed = []

            def trickle():
                start = time.monotonic()
                while not stop.is_set():
                    for conn in list(slow):
                        try:
                            conn.sendall(b"X")
                        except OSError:
                            slow.remove(conn)
                            conn.close()
                            closed.append(time.monotonic() - start)
                    stop.wait(1.0)

            thread = threading.Thread(target=trickle)
            thread.start()
            try:
                time.sleep(1.0)
                during = timed_calls(20)
                self.assertTrue(wait_until(lambda: len(closed) == 200, timeout_s=20))
            finally:
                stop.set()
                thread.join()
                for conn in slow:
                    conn.close()
            print(f"\nslowloris: calls {statistics.median(baseline) * 1e3:.1f} ms before, "
                  f"{statistics.median(during) * 1e3:.1f} ms (max {max(during) * 1e3:.1f}) with 200 "
                  f"slow connections; those cut after {max(closed):.1f} s", file=sys.stderr)
            # Before the fix every call waited 30 s; other tests share the machine under CTest -j,
            # so the bound leaves room for their load.
            self.assertLess(statistics.median(during),
                            3.0 * statistics.median(baseline) + 0.1 * TIME_SCALE)
            self.assertLess(max(during), 2.0 * TIME_SCALE)
            self.assertLess(max(closed), 10.0 + 3.0)  # the header timeout, 10 s


@needs_own_server
@unittest.skipUnless(HAVE_CHESSBOARDS, "opencv-doc not installed")
class WorkStopsWhenTheCallerIsGone(unittest.TestCase):
    """#6: a 200-pair calibration stops soon after its caller's deadline, cancel or disconnect,
    stores nothing, and does not hold up a SIGTERM."""

    @classmethod
    def setUpClass(cls):
        cls.pairs = chessboard_pairs(200)

    def assert_stopped(self, server, calibration_id, since):
        self.assertTrue(wait_until(lambda: server_metric(server, "soilvol_in_flight") == 0,
                                   timeout_s=1.0 * TIME_SCALE, step_s=0.05),
                        "in_flight stayed above 0")
        stopped_after = time.monotonic() - since
        spent = stops_working(server, settle_s=0.2, window_s=1.0)
        print(f"\n{self.id().split('.')[-1]}: in_flight 0 after {stopped_after:.2f} s, then "
              f"{spent:.2f} CPU s in 1 s", file=sys.stderr)
        self.assertLess(spent, 0.2)
        self.assertEqual(server.rest("GET", f"/v1/calibrations/{calibration_id}")[0], 404)

    def test_grpc_deadline_stops_the_calibration(self):
        grpc, pb, pb_grpc = load_grpc()
        from google.protobuf import json_format
        with Server(args=["--workers", "1"]) as server:
            request = json_format.ParseDict(calibration_json("late", self.pairs),
                                            pb.CalibrateRequest())
            with server.channel(grpc) as channel:
                stub = pb_grpc.SoilVolumeStub(channel)
                start = time.monotonic()
                with self.assertRaises(grpc.RpcError) as caught:
                    stub.Calibrate(request, timeout=3.0)
                deadline = time.monotonic()
                self.assertEqual(caught.exception.code(), grpc.StatusCode.DEADLINE_EXCEEDED)
                self.assertLess(deadline - start, 4.0)
            self.assert_stopped(server, "late", deadline)

    def test_rest_client_that_disconnects_stops_the_calibration(self):
        with Server(args=["--workers", "1"]) as server:
            body = json.dumps(calibration_json("gone", self.pairs)).encode()
            conn = http.client.HTTPConnection("127.0.0.1", server.http_port, timeout=60)
            conn.request("POST", "/v1/calibrations", body=body,
                         headers={"Content-Type": "application/json"})
            self.assertTrue(wait_until(lambda: server_metric(server, "soilvol_in_flight") == 1,
                                       timeout_s=10))
            time.sleep(1.0)
            conn.close()
            self.assert_stopped(server, "gone", time.monotonic())

    def test_sigterm_finishes_within_the_grace_period(self):
        server = Server(args=["--workers", "1", "--shutdown-grace-s", "2"]).start()
        try:
            body = json.dumps(calibration_json("term", self.pairs)).encode()
            conn = http.client.HTTPConnection("127.0.0.1", server.http_port, timeout=60)
            conn.request("POST", "/v1/calibrations", body=body,
                         headers={"Content-Type": "application/json"})
            self.assertTrue(wait_until(lambda: server_metric(server, "soilvol_in_flight") == 1,
                                       timeout_s=10))
            start = time.monotonic()
            server.proc.send_signal(signal.SIGTERM)
            code = server.proc.wait(30)
            took = time.monotonic() - start
            print(f"\nSIGTERM with a 200-pair calibration running: exit {code} after {took:.2f} s "
                  f"(grace 2 s)", file=sys.stderr)
            self.assertEqual(code, 0)
            self.assertLess(took, 2.0 + 1.5 * TIME_SCALE)
            conn.close()
            folder = os.path.join(server.data_dir, "calibrations")
            entries = os.listdir(folder) if os.path.isdir(folder) else []
            self.assertFalse([e for e in entries if "term" in e], entries)
        finally:
            server.close()


if __name__ == "__main__":
    result = unittest.main(verbosity=2, exit=False).result
    sys.exit(0 if result.wasSuccessful() else 1)
