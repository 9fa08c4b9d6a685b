"""A real browser against the REST gateway: headless Chromium (Debian `chromium`) loads a
page of another origin whose script calls soilvol with `fetch` - an `Authorization` bearer token,
`X-Request-Id` and `traceparent` headers, so a CORS preflight - and reads the JSON, the exposed
`X-Request-Id`, and a 401's google.rpc.Status; a server that does not allow the page's origin is
blocked by the browser. The page writes what it saw into the DOM, which --dump-dom prints."""
import html
import http.server
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import unittest

sys.path.insert(0, os.path.dirname(__file__))
from harness import SKIPPED, Server, needs_own_server, token_line  # noqa: E402

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
if CHROMIUM is None:
    print("skipped: chromium is not installed (scripts/install-deps.sh test)", file=sys.stderr)
    sys.exit(1 if os.environ.get("SOILVOL_REQUIRE_TOOLS") == "1" else SKIPPED)
TOKEN = "browser-token-0123456789abcdef"

PAGE = """<!doctype html>
<html><head><meta charset="utf-8"><title>soilvol CORS</title></head>
<body><pre id="result">pending</pre>
<script>
const api = "%(api)s", blocked = "%(blocked)s";
const traceparent = "00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01";
async function run() {
  const out = {};
  const r = await fetch(api + "/v1/info", {headers: {
      "Authorization": "Bearer %(token)s", "X-Request-Id": "browser-1", "traceparent": traceparent}});
  out.status = r.status;
  out.requestId = r.headers.get("X-Request-Id");
  out.version = (await r.json()).version;
  const anonymous = await fetch(api + "/v1/containers");
  out.anonymousStatus = anonymous.status;
  out.anonymousBody = await anonymous.json();
  try {
    await fetch(blocked + "/v1/info", {headers: {"Authorization": "Bearer %(token)s"}});
    out.blocked = "not blocked";
  } catch (e) {
    out.blocked = e.name;
  }
  return out;
}
run().then(out => { document.getElementById("result").textContent = JSON.stringify(out); },
           e => { document.getElementById("result").textContent = "error: " + e; });
</script></body></html>
"""


@needs_own_server
class BrowserFetch(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="soilvol-browser-")
        tokens = os.path.join(self.dir, "tokens")
        with open(tokens, "w") as f:
            f.write(token_line("dashboard", "read", TOKEN))
        os.chmod(tokens, 0o600)
        # The page's own origin: a separate HTTP server on another port.
        page = {"body": b""}

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self):  # noqa: N802 (http.server's naming)
                self.send_response(200)
                self.send_header("Content-Type", "text/html; charset=utf-8")
                self.end_headers()
                self.wfile.write(page["body"])

            def log_message(self, *args):
                pass

        self.page_server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        threading.Thread(target=self.page_server.serve_forever, daemon=True).start()
        origin = f"http://127.0.0.1:{self.page_server.server_address[1]}"
        self.server = Server(args=["--workers", "1", "--auth-tokens-file", tokens,
                                   "--cors-origin", origin], token=TOKEN).start()
        self.other = Server(args=["--workers", "1", "--auth-tokens-file", tokens],
                            token=TOKEN).start()
        page["body"] = (PAGE % {"api": self.server.base_url, "blocked": self.other.base_url,
                                "token": TOKEN}).encode()
        self.origin = origin

    def tearDown(self):
        self.server.close()
        self.other.close()
        self.page_server.shutdown()
        shutil.rmtree(self.dir, ignore_errors=True)

    def test_fetch_with_authorization_through_cors(self):
        profile = os.path.join(self.dir, "profile")
        cmd = [CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-dev-shm-usage", f"--user-data-dir={profile}", "--enable-logging=stderr",
               "--virtual-time-budget=15000", "--dump-dom", self.origin + "/"]
        result = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        match = re.search(r'<pre id="result">(.*?)</pre>', result.stdout, re.DOTALL)
        self.assertIsNotNone(match, f"no result in the page; stderr:\n{result.stderr[-3000:]}")
        text = html.unescape(match.group(1))
        self.assertTrue(text.startswith("{"), f"{text}\nstderr:\n{result.stderr[-3000:]}")
        seen = json.loads(text)
        print("the page saw:", seen)
        self.assertEqual(seen["status"], 200, seen)
        self.assertEqual(seen["requestId"], "browser-1", seen)
        self.assertRegex(seen["version"], r"^\d+\.\d+\.\d+$")
        self.assertEqual(seen["anonymousStatus"], 401, seen)
        self.assertEqual(seen["anonymousBody"]["code"], 16, seen)
        self.assertTrue(seen["anonymousBody"]["details"][0]["@type"].endswith(
            "google.rpc.ErrorInfo"), seen)
        self.assertEqual(seen["blocked"], "TypeError", seen)
        # The server saw the browser's call with its request and trace ids.
        lines = [line for line in self.server.log if "request_id=browser-1" in line]
        self.assertTrue(lines, "\n".join(self.server.log[-20:]))
        self.assertIn("trace_id=4bf92f3577b34da6a3ce929d0e0e4736", lines[0])


if __name__ == "__main__":
    unittest.main(verbosity=2)
