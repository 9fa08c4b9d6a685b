"""Production totals end to end, on SQLite and (when there is one) PostgreSQL: estimates of two
containers with materials and labels, some of them passes of truck loads and one a body scan;
GetProduction over gRPC and REST per day, shift and hour, grouped by container, haul unit,
material and label, each total checked against the records this client lists itself (body scans
counted once, in their passes); time zones and shift starts; paging; errors naming fields."""
import os
import sys
import unittest
import uuid
from collections import defaultdict

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import (Server, load_grpc, needs_own_server, needs_postgres,
                     postgres_records_args)  # noqa: E402

grpc, pb, pb_grpc = load_grpc()
from google.protobuf import timestamp_pb2  # noqa: E402

CODE = grpc.StatusCode
EMPTY = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))



def scan(fill_m, seed):
    return pb.Scan(cloud=pb.CloudScan(data=box_scene.encode_ply(box_scene.box_scan(fill_m, seed=seed))))


class ProductionContract:
    @classmethod
    def setUpClass(cls):
        cls.server = Server(args=["--workers", "2", "--site-time-zone", "America/Chicago",
                                  "--shift-starts", "07:00,19:00", *cls.records_args()]).start()
        cls.addClassCleanup(cls.server.close)  # also when the rest of the set-up fails
        cls.channel = cls.server.channel(grpc)
        cls.addClassCleanup(cls.channel.close)
        cls.stub = pb_grpc.SoilVolumeStub(cls.channel)
        p = "pr-" + uuid.uuid4().hex[:8]
        cls.a, cls.b, cls.body = p + "-a", p + "-b", p + "-body"
        cls.prefix = p
        for cid, material, site in ((cls.a, "clay", "north"), (cls.b, "sand", "south"),
                                    (cls.body, "clay", "north")):
            cls.stub.RegisterContainer(pb.RegisterContainerRequest(
                container_id=cid, scan=pb.Scan(cloud=pb.CloudScan(data=EMPTY)), overwrite=True,
                material=pb.Material(name=material, density_kg_m3=1500 if material == "clay" else 0),
                labels={"site": site},
                opening=pb.Opening(corners=[pb.Point3(x=x, y=y, z=z)
                                            for x, y, z in box_scene.opening_corners()])),
                timeout=60)
        cls.before = cls.now()
        load = cls.stub.CreateLoad(pb.CreateLoadRequest(load=pb.Load(
            haul_unit_id=p + "-truck", body_container_id=cls.body)), timeout=30)
        cls.kept = []
        for i, (cid, fill, load_id) in enumerate([
                (cls.a, 0.10, load.load_id), (cls.a, 0.20, load.load_id), (cls.b, 0.15, ""),
                (cls.a, 0.05, ""), (cls.b, 0.25, load.load_id), (cls.body, 0.40, load.load_id)]):
            cls.kept.append(cls.stub.EstimateVolume(pb.EstimateVolumeRequest(
                container_id=cid, scan=scan(fill, 40 + i), load_id=load_id, omit_heightmap=True),
                timeout=60))
        cls.after = cls.now()

    @staticmethod
    def now():
        t = timestamp_pb2.Timestamp()
        t.GetCurrentTime()
        return t

    def production(self, **fields):
        fields.setdefault("start_time", timestamp_pb2.Timestamp(seconds=self.before.seconds - 3600))
        fields.setdefault("end_time", timestamp_pb2.Timestamp(seconds=self.after.seconds + 3600))
        return self.stub.GetProduction(pb.GetProductionRequest(**fields), timeout=30)

    def expected(self, key):
        """The records' totals by `key` (estimate -> group), body scans left out."""
        totals = defaultdict(lambda: defaultdict(float))
        for e in self.kept:
            if e.load_role == pb.LOAD_ROLE_BODY_SCAN:
                continue
            t = totals[key(e)]
            t["passes"] += 1
            t["volume"] += e.volume_m3
            t["bank"] += e.load.bank_volume_m3
            t["mass"] += e.mass_kg if e.HasField("mass_kg") else 0.0
            t["mass_passes"] += e.HasField("mass_kg")
            t["fill"] += e.fill_ratio
        return totals

    def check(self, rows, expected):
        got = defaultdict(lambda: defaultdict(float))
        for row in rows:  # the estimates may straddle a period boundary: sum the periods
            g = got[row.group]
            g["passes"] += row.passes
            g["volume"] += row.volume_m3
            g["bank"] += row.bank_volume_m3
            g["mass"] += row.mass_kg
            g["mass_passes"] += row.mass_passes
            g["fill"] += row.mean_fill_ratio * row.passes
        self.assertEqual(set(got), set(expected))
        for group, want in expected.items():
            for field, value in want.items():
                self.assertAlmostEqual(got[group][field], value, places=9, msg=(group, field))

    def test_totals_equal_the_records_by_every_grouping(self):
        ours = {self.a, self.b, self.body}
        truck = self.prefix + "-truck"
        groupings = [
            (pb.PRODUCTION_GROUPING_CONTAINER, {}, lambda e: e.container_id),
            (pb.PRODUCTION_GROUPING_HAUL_UNIT, {}, lambda e: truck if e.load_id else ""),
            (pb.PRODUCTION_GROUPING_MATERIAL, {}, lambda e: "clay" if e.container_id != self.b else "sand"),
            (pb.PRODUCTION_GROUPING_LABEL, {"label_key": "site"},
             lambda e: "north" if e.container_id != self.b else "south"),
        ]
        for grouping, extra, key in groupings:
            with self.subTest(grouping=grouping):
                rows = self.production(group_by=grouping, period=pb.PRODUCTION_PERIOD_HOUR, **extra).rows
                if grouping == pb.PRODUCTION_GROUPING_CONTAINER:
                    rows = [r for r in rows if r.group in ours]  # other tests' containers
                elif grouping == pb.PRODUCTION_GROUPING_HAUL_UNIT:
                    rows = [r for r in rows if r.group == truck]
                    want = {k: v for k, v in self.expected(key).items() if k == truck}
                    self.check(rows, want)
                    self.assertEqual(sum(r.loads for r in rows), 1)
                    continue
                else:
                    continue  # shared by other classes' records on PostgreSQL: see below
                self.check(rows, self.expected(key))

    def test_periods_are_the_sites(self):
        day = self.production(period=pb.PRODUCTION_PERIOD_DAY)
        self.assertEqual(day.time_zone, "America/Chicago")
        self.assertEqual(list(day.shift_starts), ["07:00", "19:00"])
        for row in day.rows:  # Chicago midnight is 05:00 or 06:00 UTC
            self.assertIn(row.start_time.seconds % 86400, (5 * 3600, 6 * 3600))
        shifts = self.production(period=pb.PRODUCTION_PERIOD_SHIFT, time_zone="Asia/Kolkata",
                                 shift_starts=["22:00", "06:00", "14:00"])
        self.assertEqual(list(shifts.shift_starts), ["06:00", "14:00", "22:00"])
        for row in shifts.rows:  # 8-hour shifts starting at 00:30, 08:30, 16:30 UTC
            self.assertEqual(row.end_time.seconds - row.start_time.seconds, 8 * 3600)
            self.assertEqual(row.start_time.seconds % (8 * 3600), 1800)
            self.assertIn("shift", row.period)

    def test_pages_and_rest(self):
        everything = self.production(period=pb.PRODUCTION_PERIOD_HOUR,
                                     group_by=pb.PRODUCTION_GROUPING_CONTAINER)
        seen, token = [], ""
        while True:
            page = self.production(period=pb.PRODUCTION_PERIOD_HOUR, page_size=1, page_token=token,
                                   group_by=pb.PRODUCTION_GROUPING_CONTAINER)
            seen += list(page.rows)
            token = page.next_page_token
            if not token:
                break
        self.assertEqual(seen, list(everything.rows))
        start = self.before.ToJsonString()
        end = timestamp_pb2.Timestamp(seconds=self.after.seconds + 3600).ToJsonString()
        status, body = self.server.rest(
            "GET", f"/v1/production?startTime={start}&endTime={end}&groupBy=PRODUCTION_GROUPING_CONTAINER"
                   "&period=PRODUCTION_PERIOD_SHIFT")
        self.assertEqual(status, 200, body)
        mine = [r for r in body["rows"] if r["group"] == self.a]
        self.assertEqual(sum(int(r["passes"]) for r in mine), 3)
        self.assertIn("statusCounts", mine[0])

    def test_exports_stream_the_lists_as_csv_and_json_lines(self):
        import csv
        import io
        import json
        import urllib.request

        def fetch(path):
            with urllib.request.urlopen(self.server.base_url + path, timeout=60) as answer:
                return answer.headers, answer.read().decode()

        # A container's records, newest first, as ListEstimates has them.
        head, text = fetch(f"/v1/containers/{self.a}/estimates:export")
        self.assertEqual(head["Content-Type"], "text/csv; charset=utf-8")
        self.assertIn("attachment", head["Content-Disposition"])
        rows = list(csv.DictReader(io.StringIO(text)))
        mine = [e for e in self.kept if e.container_id == self.a]
        self.assertEqual([r["estimate_id"] for r in rows], [e.estimate_id for e in reversed(mine)])
        for row, e in zip(rows, reversed(mine)):
            self.assertAlmostEqual(float(row["volume_m3"]), e.volume_m3, places=6)
            self.assertEqual(row["load_id"], e.load_id)
        # The truck's loads as JSON lines.
        truck = self.prefix + "-truck"
        head, text = fetch(f"/v1/loads:export?format=jsonl&haulUnitId={truck}")
        self.assertEqual(head["Content-Type"], "application/x-ndjson")
        loads = [json.loads(line) for line in text.splitlines()]
        self.assertEqual(len(loads), 1)
        self.assertEqual(loads[0]["haulUnitId"], truck)
        self.assertEqual(loads[0]["passCount"], 3)
        # Production: the rows GetProduction gives for the same request.
        start = timestamp_pb2.Timestamp(seconds=self.before.seconds - 3600).ToJsonString()
        end = timestamp_pb2.Timestamp(seconds=self.after.seconds + 3600).ToJsonString()
        query = (f"startTime={start}&endTime={end}&period=PRODUCTION_PERIOD_HOUR"
                 "&groupBy=PRODUCTION_GROUPING_CONTAINER")
        _, text = fetch(f"/v1/production:export?{query}")
        exported = list(csv.DictReader(io.StringIO(text)))
        _, listed = self.server.rest("GET", f"/v1/production?{query}&pageSize=1000")
        self.assertEqual([(r["period"], r["group"]) for r in exported],
                         [(r["period"], r["group"]) for r in listed["rows"]])
        self.assertEqual(sum(int(r["passes"]) for r in exported),
                         sum(int(r["passes"]) for r in listed["rows"]))
        for path, field in ((f"/v1/loads:export?format=xlsx", "format"),
                            ("/v1/production:export", "start_time")):
            status, body = self.server.rest("GET", path)
            self.assertEqual(status, 400, body)
            self.assertTrue(body["message"].startswith(field), body)

    def test_bad_requests_name_their_field(self):
        start = timestamp_pb2.Timestamp(seconds=1_700_000_000)
        cases = [
            ({"start_time": None}, "start_time"),
            ({"end_time": timestamp_pb2.Timestamp(seconds=1_690_000_000)}, "end_time"),
            ({"end_time": timestamp_pb2.Timestamp(seconds=1_700_000_000 + 401 * 86400)}, "end_time"),
            ({"time_zone": "Mars/Olympus"}, "time_zone"),
            ({"shift_starts": ["06:10"]}, "shift_starts"),
            ({"shift_starts": ["06:00", "06:00"]}, "shift_starts"),
            ({"group_by": pb.PRODUCTION_GROUPING_LABEL, "label_key": "Bad Key"}, "label_key"),
            ({"page_token": "zz"}, "page_token"),
            ({"page_size": -1}, "page_size"),
        ]
        for fields, field in cases:
            request = {"start_time": start, "end_time": timestamp_pb2.Timestamp(seconds=1_700_086_400)}
            request.update(fields)
            request = {k: v for k, v in request.items() if v is not None}
            with self.subTest(field=field, fields=str(fields)):
                with self.assertRaises(grpc.RpcError) as error:
                    self.stub.GetProduction(pb.GetProductionRequest(**request), timeout=30)
                self.assertEqual(error.exception.code(), CODE.INVALID_ARGUMENT)
                self.assertTrue(error.exception.details().startswith(field), error.exception.details())


@needs_own_server
class SqliteProduction(ProductionContract, unittest.TestCase):
    @classmethod
    def records_args(cls):
        return []

    def test_material_and_label_totals(self):
        # The database is this class's alone: every group is ours.
        for grouping, extra, key in (
                (pb.PRODUCTION_GROUPING_MATERIAL, {}, lambda e: "clay" if e.container_id != self.b else "sand"),
                (pb.PRODUCTION_GROUPING_LABEL, {"label_key": "site"},
                 lambda e: "north" if e.container_id != self.b else "south"),
                (pb.PRODUCTION_GROUPING_UNSPECIFIED, {}, lambda e: "")):
            with self.subTest(grouping=grouping):
                self.check(self.production(group_by=grouping, **extra).rows, self.expected(key))


@needs_own_server
@needs_postgres
class PostgresProduction(ProductionContract, unittest.TestCase):
    records_args = staticmethod(postgres_records_args)


if __name__ == "__main__":
    unittest.main(verbosity=2)
