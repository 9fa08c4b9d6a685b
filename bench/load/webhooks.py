#!/usr/bin/python3
"""Webhooks (issue 30): a soilvol-server started here (SQLite, or PostgreSQL with --postgres URL)
posts its alerts to a receiver in this process (tests/integration/webhook_receiver.py: it checks
every signature itself).

- Healthy: ALERTS estimates over REST, one every 100 ms, each overloading its container (one
  OVERLOAD alert each); the delay of each alert is the time from its createTime to its arrival.
- Lossy: the receiver drops 20 % of the requests (half unanswered, half 503) and restarts once
  (down for 3 s) while ALERTS more are raised as fast as the estimates go; then it is healthy
  again and every alert must arrive. Reported: how many arrived, duplicates (the same alert
  posted again after a lost answer: same Idempotency-Key), alerts that came under two keys
  (must be 0), requests per alert and the time to drain.

Prints one markdown row per phase and the key=value lines behind them.
Usage: bench/load/webhooks.py [--build build] [--alerts 200] [--postgres URL]
"""
import argparse
import base64
import calendar
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "integration"))
import box_scene  # noqa: E402
from webhook_receiver import SECRET, Receiver  # noqa: E402

CONTAINER = "hooked-box"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def rest(port, method, path, body=None):
    data = json.dumps(body).encode() if body is not None else None
    request = urllib.request.Request(f"http://127.0.0.1:{port}{path}", data=data, method=method,
                                     headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=60) as answer:
        return json.loads(answer.read() or b"{}")


def seconds_since(stamp, received):
    whole, _, frac = stamp.rstrip("Z").partition(".")
    made = calendar.timegm(time.strptime(whole, "%Y-%m-%dT%H:%M:%S")) + float("0." + (frac or "0"))
    return received - made


def start_server(build, folder, receiver, records_url):
    secret = os.path.join(folder, "secret")
    with open(secret, "wb") as f:
        f.write(SECRET)
    hooks = os.path.join(folder, "webhooks.json")
    hook_id = "bench-" + os.urandom(4).hex()
    with open(hooks, "w") as f:
        json.dump({"webhooks": [{"webhookId": hook_id, "secretFile": secret,
                                 "url": f"http://127.0.0.1:{receiver.port}/hook",
                                 "containerIds": [CONTAINER]}]}, f)
    http_port = free_port()
    args = [os.path.join(build, "server", "soilvol-server"), "--grpc-address",
            f"127.0.0.1:{free_port()}", "--http-address", f"127.0.0.1:{http_port}",
            "--data-dir", os.path.join(folder, "data"), "--log-level", "warn",
            "--webhooks-file", hooks]
    if records_url:
        args += ["--records-url", records_url]
    proc = subprocess.Popen(args)
    for _ in range(200):
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{http_port}/readyz", timeout=1)
            return proc, http_port, hook_id
        except OSError:
            time.sleep(0.05)
    raise RuntimeError("the server did not become ready")


def register(port):
    empty = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))
    rest(port, "POST", "/v1/containers", {
        "containerId": CONTAINER, "overwrite": True,
        "scan": {"cloud": {"data": base64.b64encode(empty).decode()}},
        "opening": {"corners": [{"x": x, "y": y, "z": z} for x, y, z in box_scene.opening_corners()]},
        "loadTargets": {"volumeM3": 0.05}})


def overload(port, seed):
    scan = box_scene.encode_ply(box_scene.box_scan(0.2, seed=seed))
    answer = rest(port, "POST", f"/v1/containers/{CONTAINER}:estimate", {
        "scan": {"cloud": {"data": base64.b64encode(scan).decode()}}, "omitHeightmap": True})
    assert answer.get("alerts"), answer


def healthy_phase(port, receiver, count):
    receiver.drop = 0.0
    start = len(receiver.accepted)
    for i in range(count):
        overload(port, 1000 + i)
        time.sleep(0.1)
    deadline = time.time() + 60
    while len(receiver.accepted) < start + count and time.time() < deadline:
        time.sleep(0.05)
    delays = sorted(seconds_since(alert["createTime"], received) * 1000
                    for _, _, _, received, alert in receiver.accepted[start:])
    return {"arrived": len(delays), "p50_ms": statistics.median(delays),
            "p95_ms": delays[int(0.95 * (len(delays) - 1))], "max_ms": delays[-1]}


def lossy_phase(port, receiver, count):
    receiver.drop = 0.2
    requests_before, start = receiver.requests, len(receiver.accepted)
    before = set(receiver.keys_by_alert())
    begin = time.time()
    for i in range(count):
        overload(port, 5000 + i)
        if i == count // 2:
            receiver.stop()
            time.sleep(3.0)
            receiver.start()
    raised = {a["alertId"] for a in rest(port, "GET", f"/v1/alerts?containerId={CONTAINER}"
                                                      f"&pageSize=1000")["alerts"]} - before
    deadline = time.time() + 300
    while not raised <= set(receiver.keys_by_alert()) and time.time() < deadline:
        time.sleep(0.1)
    drained_s = time.time() - begin
    receiver.drop = 0.0
    keys = receiver.keys_by_alert()
    accepted = receiver.accepted[start:]
    posted = {}
    for alert_id, _, _, _, _ in accepted:
        posted[alert_id] = posted.get(alert_id, 0) + 1
    return {"raised": len(raised), "arrived": len(raised & set(keys)),
            "duplicates": sum(n - 1 for a, n in posted.items() if a in raised),
            "two_keys": sum(1 for a in raised if len(keys.get(a, ())) > 1),
            "requests_per_alert": (receiver.requests - requests_before) / max(1, len(raised)),
            "drained_s": drained_s, "bad_signatures": receiver.bad_signatures}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--alerts", type=int, default=200)
    parser.add_argument("--postgres", default="", help="libpq URL of the records database")
    args = parser.parse_args()
    receiver = Receiver(drop=0.0).start()
    folder = tempfile.mkdtemp(prefix="soilvol-webhooks-bench-")
    proc, port, _ = start_server(os.path.abspath(args.build), folder, receiver, args.postgres)
    try:
        register(port)
        healthy = healthy_phase(port, receiver, args.alerts)
        lossy = lossy_phase(port, receiver, args.alerts)
    finally:
        proc.terminate()
        proc.wait(30)
        receiver.stop()
    store = "PostgreSQL" if args.postgres else "SQLite"
    print(" ".join(f"healthy_{k}={v:.1f}" if isinstance(v, float) else f"healthy_{k}={v}"
                   for k, v in healthy.items()))
    print(" ".join(f"lossy_{k}={v:.2f}" if isinstance(v, float) else f"lossy_{k}={v}"
                   for k, v in lossy.items()))
    print("| records | phase | alerts | arrived | delay p50 ms | p95 ms | max ms | duplicates "
          "| under two keys | requests per alert | drained in |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    print(f"| {store} | healthy, one every 100 ms | {args.alerts} | {healthy['arrived']} "
          f"| {healthy['p50_ms']:.1f} | {healthy['p95_ms']:.1f} | {healthy['max_ms']:.1f} | 0 | 0 "
          f"| 1.00 | |")
    print(f"| {store} | 20 % dropped, one 3 s restart | {lossy['raised']} | {lossy['arrived']} "
          f"| | | | {lossy['duplicates']} | {lossy['two_keys']} "
          f"| {lossy['requests_per_alert']:.2f} | {lossy['drained_s']:.1f} s |")
    return 0 if lossy["arrived"] == lossy["raised"] and lossy["two_keys"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
