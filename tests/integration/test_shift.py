"""Issue 30's simulated shift through the public API: `soilvol demo-shift` (the CLI, over gRPC)
has an excavator load 20 trucks with 4-6 passes each, scans from core/sim, one body scan per
load at the exit; this test then reads every load and its records back with its own client and
checks that the loads' totals are the sums of their records, that every pass and body scan is
where the load says, and that the reconciliation is the body record against the passes. Whether
the body agrees with the passes within 2 sigma (issue 30's target: 90% of loads) is measured over
seeds by bench/load/shift.py (BENCHMARK.md), not asserted here. On SQLite and, when there is
one, PostgreSQL."""
import json
import os
import subprocess
import sys
import unittest
import uuid

sys.path.insert(0, os.path.dirname(__file__))
from harness import (Server, load_grpc, needs_own_server, needs_postgres,
                     postgres_records_args)  # noqa: E402

grpc, pb, pb_grpc = load_grpc()
CLI = os.environ.get("SOILVOL_CLI_BIN", "")
TRUCKS = 20



class ShiftContract:
    def test_a_shift_of_twenty_trucks(self):
        prefix = "sh-" + uuid.uuid4().hex[:8]
        with Server(args=["--workers", "2", *self.records_args()]) as server:
            done = subprocess.run(
                [CLI, "--server", server.grpc_target, "--json", "demo-shift", "--trucks",
                 str(TRUCKS), "--prefix", prefix, "--seed", "3"],
                capture_output=True, text=True, timeout=600)
            self.assertEqual(done.returncode, 0, done.stderr)
            rows = json.loads(done.stdout)
            self.assertEqual(len(rows), TRUCKS)
            channel = server.channel(grpc)
            stub = pb_grpc.SoilVolumeStub(channel)
            agree = 0
            for row in rows:
                load = stub.GetLoad(pb.GetLoadRequest(load_id=row["loadId"]), timeout=30)
                self.assertEqual(load.haul_unit_id, row["haulUnitId"])
                self.assertIn(load.pass_count + row["unmeasured"], range(4, 7))
                self.assertEqual(load.pass_count, row["passes"])
                self.assertEqual(load.state, pb.LOAD_STATE_CLOSED)
                self.assertEqual(load.close_reason, pb.LOAD_CLOSE_REASON_EXPLICIT)
                # The totals are the sum of the records this client reads.
                volumes = [stub.GetEstimate(pb.GetEstimateRequest(
                    container_id=p.container_id, estimate_id=p.estimate_id,
                    view=pb.ESTIMATE_VIEW_BASIC), timeout=30).result.volume_m3
                    for p in load.passes]
                self.assertEqual(len(volumes), load.pass_count)
                self.assertAlmostEqual(load.volume_m3, sum(volumes), places=9)
                if not row["reconciled"]:  # its body scan was refused three times
                    self.assertFalse(load.HasField("reconciliation"))
                    continue
                body = stub.GetEstimate(pb.GetEstimateRequest(
                    container_id=prefix + "-truck-body",
                    estimate_id=load.reconciliation.estimate_id), timeout=30).result
                self.assertEqual(body.load_role, pb.LOAD_ROLE_BODY_SCAN)
                self.assertAlmostEqual(load.reconciliation.difference_m3,
                                       body.volume_m3 - load.volume_m3, places=9)
                agree += load.reconciliation.within_two_sigma
            print(f"body scan within 2 sigma of the passes: {agree} of {TRUCKS}", file=sys.stderr)
            self.assertEqual(agree, sum(r["withinTwoSigma"] for r in rows))
            # Every load of the shift is listed for its haul unit, newest first.
            listed = stub.ListLoads(pb.ListLoadsRequest(haul_unit_id=rows[0]["haulUnitId"]),
                                    timeout=30)
            self.assertEqual([l.load_id for l in listed.loads], [rows[0]["loadId"]])
            channel.close()


@needs_own_server
@unittest.skipUnless(CLI, "needs the soilvol CLI ($SOILVOL_CLI_BIN)")
class SqliteShift(ShiftContract, unittest.TestCase):
    def records_args(self):
        return []


@needs_own_server
@unittest.skipUnless(CLI, "needs the soilvol CLI ($SOILVOL_CLI_BIN)")
@needs_postgres
class PostgresShift(ShiftContract, unittest.TestCase):
    records_args = staticmethod(postgres_records_args)


if __name__ == "__main__":
    unittest.main(verbosity=2)
