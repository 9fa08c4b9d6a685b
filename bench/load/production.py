#!/usr/bin/python3
"""GetProduction over 1M records (issue 30: <= 200 ms on SQLite and on PostgreSQL): a database
of N records over 30 days (20 excavators taking turns, loads of 4-6 passes of 60 trucks) made by
soilvol-records-gen through the server's own RecordStore, then a soilvol-server on it and
GetProduction over gRPC from here, each query ROUNDS times (median and max, in ms, the round
trip as a client sees it); then every record exported as CSV over REST (GET
/v1/containers/-/estimates:export), read here at full speed: the rows, the time and the server's
resident memory (its /metrics) before and at the end. PostgreSQL: a server started here (scripts/test-postgres.sh); the
generator commits without waiting for the disk (synchronous_commit off: the figures are the
queries', not the generation's).
Usage: bench/load/production.py [--build build] [--records 1000000] [--rounds 7]
       [--databases sqlite,postgresql]
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "tests", "integration"))


def resident_bytes(server):
    import urllib.request
    with urllib.request.urlopen(server.base_url + "/metrics", timeout=30) as answer:
        for line in answer.read().decode().splitlines():
            if line.startswith("process_resident_memory_bytes "):
                return float(line.split()[1])
    return float("nan")


def export_row(server, name):
    """Every record as CSV, read as fast as this process can: rows, seconds, resident memory."""
    import urllib.request
    before = resident_bytes(server)
    peak = before
    start = time.perf_counter()
    rows = 0
    url = server.base_url + "/v1/containers/-/estimates:export?format=csv&registrationId=-"
    with urllib.request.urlopen(url, timeout=600) as answer:
        while True:
            block = answer.read(1 << 20)
            if not block:
                break
            rows += block.count(b"\n")
            if rows % 50 < 5:
                peak = max(peak, resident_bytes(server))
    seconds = time.perf_counter() - start
    after = resident_bytes(server)
    return (f"<!-- {name}: exported {rows - 1} records as CSV in {seconds:.1f} s; server resident "
            f"memory {before / 2**20:.0f} MiB before, {max(peak, after) / 2**20:.0f} MiB at most "
            f"seen, {after / 2**20:.0f} MiB after -->")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default="build")
    parser.add_argument("--records", type=int, default=1_000_000)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--databases", default="sqlite,postgresql")
    args = parser.parse_args()
    build = os.path.abspath(args.build)
    os.environ.setdefault("SOILVOL_SERVER_BIN", os.path.join(build, "server", "soilvol-server"))
    os.environ.setdefault("SOILVOL_PROTO_PYTHON", os.path.join(build, "proto", "python"))
    from harness import Server, load_grpc  # noqa: E402
    grpc, pb, pb_grpc = load_grpc()
    from google.protobuf import timestamp_pb2  # noqa: E402
    work = tempfile.mkdtemp(prefix="soilvol-production-")
    pg = tempfile.mkdtemp(prefix="soilvol-production-pg-")
    subprocess.run([os.path.join(ROOT, "scripts", "test-postgres.sh"), "start", pg], check=True,
                   capture_output=True)
    try:
        backends = {
            "sqlite": f"sqlite:{work}/records.sqlite3",
            "postgresql": f"postgresql:///postgres?host={pg}&user=soilvol",
        }
        end_us = int(time.time() * 1e6)
        print("| database | query | rows | median ms | max ms |")
        print("|---|---|---|---|---|")
        for name, url in backends.items():
            if name not in args.databases.split(","):
                continue
            gen_url = url + ("&options=-c%20synchronous_commit%3Doff" if name == "postgresql" else "")
            made = subprocess.run(
                [os.path.join(build, "bench", "soilvol-records-gen"), "--url", gen_url, "--records",
                 str(args.records), "--end-us", str(end_us)], check=True, capture_output=True, text=True)
            print(f"<!-- {name}: {made.stdout.strip()} -->")
            # Retention off: the server keeps what was generated (its defaults would prune the
            # records to 10000 a container at start; production is never pruned).
            with Server(data_dir=work, args=["--workers", "2", "--records-url", url,
                                              "--site-time-zone", "Europe/Berlin",
                                              "--records-max-per-container", "100000000",
                                              "--records-max-age-days", "36500"]) as server:
                channel = server.channel(grpc)
                stub = pb_grpc.SoilVolumeStub(channel)
                day = 86400
                end = timestamp_pb2.Timestamp(seconds=end_us // 1_000_000)
                queries = [
                    ("a day by hour", day, pb.PRODUCTION_PERIOD_HOUR, pb.PRODUCTION_GROUPING_UNSPECIFIED),
                    ("a week by shift and container", 7 * day, pb.PRODUCTION_PERIOD_SHIFT,
                     pb.PRODUCTION_GROUPING_CONTAINER),
                    ("30 days by day and haul unit", 30 * day, pb.PRODUCTION_PERIOD_DAY,
                     pb.PRODUCTION_GROUPING_HAUL_UNIT),
                    ("30 days by shift and material", 30 * day, pb.PRODUCTION_PERIOD_SHIFT,
                     pb.PRODUCTION_GROUPING_MATERIAL),
                    ("30 days by hour", 30 * day, pb.PRODUCTION_PERIOD_HOUR,
                     pb.PRODUCTION_GROUPING_UNSPECIFIED),
                ]
                for label, span, period, grouping in queries:
                    request = pb.GetProductionRequest(
                        start_time=timestamp_pb2.Timestamp(seconds=end.seconds - span), end_time=end,
                        period=period, group_by=grouping, page_size=1000)
                    times, rows = [], 0
                    for _ in range(args.rounds):
                        start = time.perf_counter()
                        answer = stub.GetProduction(request, timeout=60)
                        times.append(1000 * (time.perf_counter() - start))
                        rows = len(answer.rows)
                    print(f"| {name} | {label} | {rows} | {statistics.median(times):.1f} | {max(times):.1f} |")
                total = stub.GetProduction(pb.GetProductionRequest(
                    start_time=timestamp_pb2.Timestamp(seconds=end.seconds - 31 * day), end_time=end,
                    period=pb.PRODUCTION_PERIOD_DAY), timeout=60)
                passes = sum(r.passes for r in total.rows)
                print(f"<!-- {name}: the rollup counts {passes} passes of {args.records} records -->")
                channel.close()
                print(export_row(server, name))
    finally:
        subprocess.run([os.path.join(ROOT, "scripts", "test-postgres.sh"), "stop", pg], capture_output=True)
        subprocess.run(["rm", "-rf", work, pg])


if __name__ == "__main__":
    main()
