#!/usr/bin/env python3
"""A reference receiver of soilvol's webhooks (standard library only): checks each request's
Soilvol-Signature (t=<unix s>,v1=<hex HMAC-SHA256 of "<t>.<body>"> under the shared secret, at
most 5 minutes old), answers 204 and prints the alert as one JSON line; a repeated
Idempotency-Key (a retry whose answer was lost) is acknowledged and not printed again. A bad or
stale signature gets 401, which soilvol retries with backoff.

    python3 scripts/webhook-receiver.py --listen localhost:9000 --secret-file webhook.secret
"""
import argparse
import hashlib
import hmac
import http.server
import json
import sys
import threading
import time

TOLERANCE_S = 300


def signature_ok(header, secret, body, now):
    fields = {}
    for part in header.split(","):
        key, _, value = part.strip().partition("=")
        fields.setdefault(key, []).append(value)
    try:
        stamp = int(fields["t"][0])
    except (KeyError, ValueError):
        return False
    if abs(now - stamp) > TOLERANCE_S:
        return False
    expected = hmac.new(secret, str(stamp).encode() + b"." + body, hashlib.sha256).hexdigest()
    return any(hmac.compare_digest(expected, v) for v in fields.get("v1", []))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--listen", default="localhost:9000", help="host:port")
    parser.add_argument("--secret-file", required=True)
    args = parser.parse_args()
    with open(args.secret_file, "rb") as f:
        secret = f.read().rstrip(b"\r\n")
    seen, lock = set(), threading.Lock()

    class Handler(http.server.BaseHTTPRequestHandler):
        def log_message(self, fmt, *values):
            print(fmt % values, file=sys.stderr)

        def do_POST(self):
            length = int(self.headers.get("Content-Length") or 0)
            if length > 1 << 20:
                self.send_error(413)
                return
            body = self.rfile.read(length)
            if not signature_ok(self.headers.get("Soilvol-Signature", ""), secret, body,
                                int(time.time())):
                self.send_error(401, "bad signature")
                return
            key = self.headers.get("Idempotency-Key", "")
            with lock:
                fresh = key not in seen
                seen.add(key)
            if fresh:
                print(json.dumps(json.loads(body)), flush=True)
            self.send_response(204)
            self.end_headers()

    host, _, port = args.listen.rpartition(":")
    http.server.ThreadingHTTPServer((host, int(port)), Handler).serve_forever()


if __name__ == "__main__":
    main()
