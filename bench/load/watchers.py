#!/usr/bin/python3
"""Watch streams at a site's scale (issue 30): a soilvol-server started here, N Server-Sent Event
watchers (asyncio, one connection each, in this process), and estimates made meanwhile.

- Delivery: this script makes ESTIMATES estimates over REST one after another (a box scene,
  numpy); every watcher must receive every one of them; the delay of each delivery is the time
  from the estimate's answer arriving here to the event arriving at that watcher (clipped at 0:
  the record is committed, and can be delivered, before the answer is).
- Cost to the estimate path: soilvol-load's sequential gRPC round trips (20k points, 8 s) with no
  watcher, then with the N watchers open and receiving its estimates, alternating ROUNDS times.
- Delivery under that load: every watcher must also receive each of soilvol-load's estimates;
  the delay of each is from the record's create_time (the server's clock, the same machine's)
  to its arrival, so it includes the estimate's own time (tens of milliseconds).

The watchers stand for screens on other machines: they run in a child process at nice 19, so
that on this machine's cores they take what the server leaves (their CPU is reported); with
--idle-watchers under SCHED_IDLE instead, so that they run only on a core the server leaves
idle (nice 19 still takes a core the moment an estimate's thread waits). Prints one markdown
row per watcher count and the key=value lines behind them.
Usage: bench/load/watchers.py [--build build] [--watchers 0,1000] [--rounds 3] [--idle-watchers]
"""
import argparse
import asyncio
import os
import re
import resource
import socket
import statistics
import subprocess
import sys
import base64
import json
import tempfile
import time
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "integration"))
import box_scene  # noqa: E402

CONTAINER = "watched-box"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    def __init__(self, build, max_watches):
        self.grpc_port, self.http_port = free_port(), free_port()
        self.data = tempfile.mkdtemp(prefix="soilvol-watchers-")
        self.proc = subprocess.Popen(
            [os.path.join(build, "server", "soilvol-server"), "--grpc-address",
             f"127.0.0.1:{self.grpc_port}", "--http-address", f"127.0.0.1:{self.http_port}",
             "--data-dir", self.data, "--log-level", "warn", "--max-watches", str(max_watches)])
        for _ in range(200):
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{self.http_port}/readyz", timeout=1)
                return
            except OSError:
                time.sleep(0.05)
        raise RuntimeError("the server did not become ready")

    def post(self, path, body, content_type):
        request = urllib.request.Request(f"http://127.0.0.1:{self.http_port}{path}", data=body,
                                         headers={"Content-Type": content_type}, method="POST")
        with urllib.request.urlopen(request, timeout=60) as answer:
            return answer.read()

    def close(self):
        self.proc.terminate()
        self.proc.wait(timeout=30)
        subprocess.run(["rm", "-rf", self.data], check=False)


class Watcher:
    """One SSE stream: the receive time of each estimate id."""

    def __init__(self):
        self.seen = {}
        self.ready = asyncio.Event()

    async def run(self, port):
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        writer.write(b"GET /v1/estimates:watch HTTP/1.1\r\nHost: bench\r\n"
                     b"Accept: text/event-stream\r\n\r\n")
        await writer.drain()
        try:
            while True:
                line = await reader.readline()
                if not line:
                    return
                if line.startswith(b": watching"):
                    self.ready.set()
                elif line.startswith(b"id: "):
                    self.seen[line[4:].strip().decode()] = time.time()
        finally:
            writer.close()


def estimate_ply(fill):
    return box_scene.encode_ply(box_scene.box_scan(fill, seed=7))


def make_estimates(server, count, answered):
    for i in range(count):
        body = server.post(f"/v1/containers/{CONTAINER}:estimate?omitHeightmap=true",
                           estimate_ply(0.05 + 0.3 * i / max(count, 1)),
                           "application/octet-stream")
        estimate_id = re.search(rb'"estimateId":\s*"(\d+)"', body).group(1).decode()
        answered[estimate_id] = time.time()
        time.sleep(0.2)


def cpu_seconds(pid):
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def load_p50(build, server, watchers_pid):
    """soilvol-load's p50 [ms], and the CPU the server and the watchers spent per estimate
    meanwhile [ms]."""
    server_before, own_before = cpu_seconds(server.proc.pid), cpu_seconds(watchers_pid)
    run = subprocess.run(
        [os.path.join(build, "bench", "soilvol-load"), "--grpc", f"127.0.0.1:{server.grpc_port}",
         "--http", f"127.0.0.1:{server.http_port}", "--transport", "grpc", "--clients", "1",
         "--points", "20000", "--seconds", "8"], capture_output=True, text=True, check=True)
    calls = int(re.search(r"calls=(\d+)", run.stdout).group(1))
    return (float(re.search(r"p50_ms=([\d.]+)", run.stdout).group(1)),
            1000 * (cpu_seconds(server.proc.pid) - server_before) / calls,
            1000 * (cpu_seconds(watchers_pid) - own_before) / calls)


async def watch(port, count):
    """The child: `count` watchers; "ready" on stdout once all stream, then at a line on stdin
    each watcher's {estimate id: receive time} as one JSON line and its CPU seconds."""
    watchers = [Watcher() for _ in range(count)]
    tasks = [asyncio.create_task(w.run(port)) for w in watchers]
    await asyncio.wait_for(asyncio.gather(*(w.ready.wait() for w in watchers)), 60)
    print("ready", flush=True)
    await asyncio.to_thread(sys.stdin.readline)
    print(json.dumps({"seen": [w.seen for w in watchers], "cpu_s": time.process_time()}),
          flush=True)
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)


def created_times(server):
    """{estimate id: its create_time [s since the epoch]} of every record kept."""
    created, token = {}, ""
    while True:
        with urllib.request.urlopen(f"http://127.0.0.1:{server.http_port}/v1/containers/-/estimates"
                                    f"?pageSize=1000&pageToken={token}", timeout=60) as answer:
            page = json.loads(answer.read())
        for e in page.get("estimates", []):
            stamp = e["createTime"].rstrip("Z")
            whole, _, fraction = stamp.partition(".")
            created[e["estimateId"]] = (time.mktime(time.strptime(whole, "%Y-%m-%dT%H:%M:%S"))
                                        - time.timezone + float("0." + (fraction or "0")))
        token = page.get("nextPageToken", "")
        if not token:
            return created


def measure(build, server, count, estimates):
    before = set(created_times(server))
    priority = ["chrt", "--idle", "0"] if args.idle_watchers else ["nice", "-n", "19"]
    child = subprocess.Popen(
        priority + [sys.executable, os.path.abspath(__file__), "--child-port",
                    str(server.http_port), "--watchers", str(count)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    if child.stdout.readline().strip() != "ready":
        raise RuntimeError("the watchers did not start")
    answered = {}
    make_estimates(server, estimates, answered)
    time.sleep(2.0)  # what is still on its way
    p50s = [load_p50(build, server, child.pid) for _ in range(args.rounds)]
    time.sleep(2.0)  # the last estimates' events are still on their way to some watchers
    child.stdin.write("dump\n")
    child.stdin.flush()
    report = json.loads(child.stdout.readline())
    child.wait(timeout=60)
    seen = report["seen"]
    delays = [max(0.0, w[i] - t) for w in seen for i, t in answered.items() if i in w]
    loaded = {i: t for i, t in created_times(server).items()
              if i not in answered and i not in before}
    under_load = [w[i] - t for w in seen for i, t in loaded.items() if i in w]
    return (delays, count * len(answered) - len(delays), p50s, under_load,
            count * len(loaded) - len(under_load))


def main():
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)  # a socket per watcher here too
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    server = Server(args.build, max(args.watchers) + 16)
    try:
        server.post("/v1/containers", (
            '{"containerId": "%s", "scan": {"cloud": {"data": "%s"}}, "opening": {"corners": [%s]}}'
            % (CONTAINER, base64.b64encode(box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))).decode(),
               ", ".join('{"x": %r, "y": %r, "z": %r}' % c for c in box_scene.opening_corners()))
        ).encode(), "application/json")
        rows = []
        for count in args.watchers:
            delays, missing, p50s, loaded, loaded_missing = measure(args.build, server, count,
                                                                    args.estimates)
            delays.sort()
            loaded.sort()
            lq = (lambda f: 1000 * loaded[min(len(loaded) - 1, int(f * len(loaded)))]
                  if loaded else float("nan"))
            q = (lambda f: 1000 * delays[min(len(delays) - 1, int(f * len(delays)))]
                 if delays else float("nan"))
            p50 = statistics.median(p for p, _, _ in p50s)
            server_ms = statistics.median(c for _, c, _ in p50s)
            watcher_ms = statistics.median(w for _, _, w in p50s)
            print(f"watchers={count} deliveries={len(delays)} missing={missing} "
                  f"delay_p50_ms={q(0.5):.1f} delay_p99_ms={q(0.99):.1f} "
                  f"delay_max_ms={1000 * max(delays, default=float('nan')):.1f} "
                  f"estimate_p50_ms={' '.join(f'{p:.1f}' for p, _, _ in p50s)} "
                  f"server_cpu_ms_per_estimate={server_ms:.1f} "
                  f"watchers_cpu_ms_per_estimate={watcher_ms:.1f} "
                  f"under_load_deliveries={len(loaded)} under_load_missing={loaded_missing} "
                  f"under_load_delay_p50_ms={lq(0.5):.1f} under_load_delay_p99_ms={lq(0.99):.1f} "
                  f"under_load_delay_max_ms={1000 * max(loaded, default=float('nan')):.1f}",
                  flush=True)
            rows.append((count, len(delays), missing, q(0.5), q(0.99),
                         1000 * max(delays, default=float("nan")), p50, server_ms, watcher_ms,
                         len(loaded), loaded_missing, lq(0.5), lq(0.99),
                         1000 * max(loaded, default=float("nan"))))
        base = rows[0][6]
        print("| watchers | deliveries (missing) | delay p50 / p99 / max ms | estimate p50 ms "
              "(20k points, gRPC) | vs no watcher | server CPU ms per estimate | watchers' CPU "
              "ms per estimate | under load: deliveries (missing) | under load: delay p50 / p99 / "
              "max ms |")
        print("|---|---|---|---|---|---|---|---|---|")
        for (count, n, missing, d50, d99, dmax, p50, server_ms, watcher_ms, ln, lmissing, l50,
             l99, lmax) in rows:
            print(f"| {count} | {n} ({missing}) | {d50:.1f} / {d99:.1f} / {dmax:.1f} | "
                  f"{p50:.1f} | {p50 / base:.2f}x | {server_ms:.1f} | {watcher_ms:.1f} | "
                  f"{ln} ({lmissing}) | {l50:.1f} / {l99:.1f} / {lmax:.1f} |")
    finally:
        server.close()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--watchers", default="0,1000",
                        type=lambda s: [int(x) for x in s.split(",")])
    parser.add_argument("--estimates", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--idle-watchers", action="store_true",
                        help="run the watchers under SCHED_IDLE instead of at nice 19")
    parser.add_argument("--child-port", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child_port:
        resource.setrlimit(resource.RLIMIT_NOFILE, (resource.getrlimit(resource.RLIMIT_NOFILE)[1],) * 2)
        asyncio.run(watch(args.child_port, args.watchers[0]))
    else:
        main()
