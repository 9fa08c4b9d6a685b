"""A webhook receiver for tests and benchmarks: a real HTTP server on a fixed port that checks each
request's Soilvol-Signature itself (HMAC-SHA256 under SECRET), drops a share of the requests
(half by closing the connection unanswered, half with 503), and keeps what it accepted with the
time it arrived."""
import hashlib
import hmac
import http.server
import json
import random
import socket
import threading
import time

SECRET = b"receiver-secret-0123456789"


def verify(header, body, now_s, tolerance_s=300):
    """The Soilvol-Signature check a receiver makes: t=<unix s>,v1=<hex HMAC-SHA256>."""
    fields = dict(part.split("=", 1) for part in header.split(",") if "=" in part)
    if abs(now_s - int(fields.get("t", "0"))) > tolerance_s:
        return False
    expected = hmac.new(SECRET, fields["t"].encode() + b"." + body, hashlib.sha256).hexdigest()
    return hmac.compare_digest(expected, fields.get("v1", ""))


class Receiver:
    """A webhook endpoint on a fixed port that drops `drop` of the requests (half by closing
    the connection unanswered, half with 503) and keeps what it accepted."""

    def __init__(self, drop=0.2, seed=7):
        self.drop = drop
        self.random = random.Random(seed)
        self.lock = threading.Lock()
        self.accepted = []   # (alert_id, key, attempt, received unix s, alert)
        self.requests = 0
        self.bad_signatures = 0
        probe = socket.socket()
        probe.bind(("127.0.0.1", 0))
        self.port = probe.getsockname()[1]
        probe.close()
        self.httpd = None

    def start(self):
        receiver = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_POST(self):
                body = self.rfile.read(int(self.headers.get("Content-Length", "0")))
                now = time.time()
                with receiver.lock:
                    receiver.requests += 1
                    roll = receiver.random.random()
                if not verify(self.headers.get("Soilvol-Signature", ""), body, int(now)):
                    with receiver.lock:
                        receiver.bad_signatures += 1
                    self.send_response(401)
                    self.end_headers()
                    return
                if roll < receiver.drop / 2:
                    self.close_connection = True
                    self.connection.shutdown(socket.SHUT_RDWR)  # no answer at all
                    return
                if roll < receiver.drop:
                    self.send_response(503)
                    self.end_headers()
                    return
                alert = json.loads(body)
                with receiver.lock:
                    receiver.accepted.append((alert["alertId"], self.headers["Idempotency-Key"],
                                              int(self.headers["Soilvol-Delivery-Attempt"]), now,
                                              alert))
                self.send_response(204)
                self.end_headers()

        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", self.port), Handler)
        self.httpd.allow_reuse_address = True
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()
        return self

    def stop(self):
        self.httpd.shutdown()
        self.httpd.server_close()

    def keys_by_alert(self):
        with self.lock:
            out = {}
            for alert_id, key, _, _, _ in self.accepted:
                out.setdefault(alert_id, set()).add(key)
            return out
