"""The dashboard in a real browser: headless Chromium (Debian `chromium`) driven over the Chrome
DevTools Protocol (--remote-debugging-pipe, so no extra Python packages) loads the page the
server serves at /, with no console errors; a container registered through the API appears; an
estimate posted through the API shows up within 2 s with its status and a drawn heightmap; a
container whose capacity is unsure carries its warning on its card and in its details; the
screenshot is written to $SOILVOL_SCREENSHOT_DIR (build/screenshots) for people to look at. Run
with the server's token auth too: the page takes the token and sends it."""
import base64
import fcntl
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
import mesh_scene  # noqa: E402
from harness import SKIPPED, Server, cloud_scan, corners_json, needs_own_server, token_line  # noqa: E402

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
if CHROMIUM is None:
    print("skipped: chromium is not installed (scripts/install-deps.sh test)", file=sys.stderr)
    sys.exit(1 if os.environ.get("SOILVOL_REQUIRE_TOOLS") == "1" else SKIPPED)
SCREENSHOTS = os.environ.get("SOILVOL_SCREENSHOT_DIR", tempfile.gettempdir())
TOKEN = "dashboard-token-0123456789abcdef"


class Browser:
    """Chromium over the DevTools protocol on a pipe: commands in, events collected."""

    def __init__(self, width=1280, height=1000, zone=None):
        self.profile = tempfile.mkdtemp(prefix="soilvol-chromium-")
        to_browser_r, self.to_browser = os.pipe()
        self.from_browser, from_browser_w = os.pipe()

        def fds():  # the pipe Chromium reads at fd 3 and writes at fd 4
            high_r = fcntl.fcntl(to_browser_r, fcntl.F_DUPFD, 10)
            high_w = fcntl.fcntl(from_browser_w, fcntl.F_DUPFD, 10)
            os.dup2(high_r, 3)
            os.dup2(high_w, 4)

        # close_fds=False: only 3 and 4 (inheritable after dup2) and stdio survive the exec.
        self.proc = subprocess.Popen(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
             "--remote-debugging-pipe", f"--user-data-dir={self.profile}", "--no-first-run",
             f"--window-size={width},{height}", "about:blank"],
            close_fds=False, preexec_fn=fds, env=dict(os.environ, **({"TZ": zone} if zone else {})),
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.next_id = 0
        self.results = {}
        self.events = []
        self.lock = threading.Condition()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.session = self.call("Target.attachToTarget",
                                 {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Runtime", "Log", "Page"):
            self.call(f"{domain}.enable", session=True)

    def _read(self):
        buffer = b""
        while True:
            chunk = os.read(self.from_browser, 1 << 16)
            if not chunk:
                return
            buffer += chunk
            while b"\0" in buffer:
                raw, buffer = buffer.split(b"\0", 1)
                message = json.loads(raw)
                with self.lock:
                    if "id" in message:
                        self.results[message["id"]] = message
                    else:
                        self.events.append(message)
                    self.lock.notify_all()

    def call(self, method, params=None, session=False, timeout=30):
        with self.lock:
            self.next_id += 1
            ident = self.next_id
        message = {"id": ident, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = self.session
        os.write(self.to_browser, json.dumps(message).encode() + b"\0")
        with self.lock:
            if not self.lock.wait_for(lambda: ident in self.results, timeout):
                raise TimeoutError(method)
            answer = self.results.pop(ident)
        if "error" in answer:
            raise RuntimeError(f"{method}: {answer['error']}")
        return answer.get("result", {})

    def evaluate(self, expression):
        result = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                "awaitPromise": True}, session=True)
        if "exceptionDetails" in result:
            raise RuntimeError(result["exceptionDetails"])
        return result["result"].get("value")

    def wait_for(self, expression, timeout):
        """Whether `expression` became true within `timeout` s; while the page is still loading
        it may throw (an element not there yet), which counts as not yet."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                if self.evaluate(expression):
                    return True
            except RuntimeError:
                pass
            time.sleep(0.05)
        return False

    def errors(self):
        """Console errors, uncaught exceptions and failed loads the page reported."""
        with self.lock:
            events = list(self.events)
        found = []
        for event in events:
            method, params = event.get("method"), event.get("params", {})
            if method == "Runtime.exceptionThrown":
                found.append(params["exceptionDetails"].get("text", "exception"))
            elif method == "Runtime.consoleAPICalled" and params.get("type") == "error":
                found.append(str(params.get("args")))
            elif method == "Log.entryAdded" and params["entry"].get("level") == "error":
                found.append(params["entry"].get("text", ""))
        return found

    def screenshot(self, path):
        data = self.call("Page.captureScreenshot", {"format": "png"}, session=True)["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))

    def close(self):
        try:
            self.call("Browser.close", timeout=5)
        except Exception:  # noqa: BLE001 - closing anyway
            pass
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        os.close(self.to_browser)
        shutil.rmtree(self.profile, ignore_errors=True)


EMPTY = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))


def register(server, cid, name, target_m3):
    return server.rest("POST", "/v1/containers", {
        "containerId": cid, "displayName": name, "overwrite": True, "labels": {"site": "north"},
        "scan": cloud_scan(EMPTY), "opening": corners_json(box_scene.opening_corners()),
        "material": {"name": "clay", "densityKgM3": 1600},
        "loadTargets": {"volumeM3": target_m3, "carrybackM3": 0.01}})


def register_one_view(server, cid):
    """A bin seen from one side only: its capacity's 1-sigma is about 2% (a warning)."""
    return server.rest("POST", "/v1/containers", {
        "containerId": cid, "displayName": "Bin 3", "overwrite": True,
        "scan": cloud_scan(box_scene.encode_ply(mesh_scene.scan(0.0, seed=1))),
        "opening": corners_json(mesh_scene.scan_opening_corners())})


def estimate(server, cid, fill_m, request_id):
    scan = box_scene.encode_ply(box_scene.box_scan(fill_m, seed=len(request_id)))
    return server.rest("POST", f"/v1/containers/{cid}:estimate",
                       {"scan": cloud_scan(scan), "requestId": request_id})


@needs_own_server
class Dashboard(unittest.TestCase):
    def run_flow(self, server, screenshot_name, token=None):
        browser = Browser()
        try:
            status, _ = register(server, "truck-1", "Truck 1", 0.2)
            self.assertEqual(status, 200)
            if token:  # as a user who gave it before: the page keeps it in localStorage
                browser.call("Page.navigate", {"url": server.base_url + "/dashboard/style.css"},
                             session=True)
                self.assertTrue(browser.wait_for("document.readyState === 'complete'", 15))
                browser.evaluate(f"localStorage.setItem('soilvol.token', '{token}'); true")
            browser.call("Page.navigate", {"url": server.base_url + "/"}, session=True)
            self.assertTrue(browser.wait_for("document.readyState === 'complete'", 15))
            self.assertTrue(browser.wait_for(
                "document.querySelector('[data-container=\"truck-1\"]') !== null", 10),
                browser.errors())
            # Registered while the page is open: it appears too.
            self.assertEqual(register(server, "truck-2", "Truck 2", 0.25)[0], 200)
            self.assertTrue(browser.wait_for(
                "document.querySelector('[data-container=\"truck-2\"]') !== null", 10))
            status, warned = register_one_view(server, "bin-3")
            self.assertEqual(status, 200, warned)
            self.assertEqual(len(warned["warnings"]), 1, warned)
            # Its card carries the warning as a visible note; the others none.
            self.assertTrue(browser.wait_for(
                "(() => { const n = document.querySelector('[data-container=\"bin-3\"] .warning');"
                " return n && n.offsetHeight > 0 && n.textContent.includes('1-sigma'); })()", 10),
                browser.errors())
            self.assertEqual(browser.evaluate(
                "document.querySelectorAll('.card .warning:not(.hidden)').length"), 1)
            self.assertTrue(browser.wait_for("document.getElementById('live').textContent === 'live'", 10))
            status, answer = estimate(server, "truck-1", 0.2, "browser-load-1")
            self.assertEqual(status, 200, answer)
            posted = time.monotonic()
            shown = browser.wait_for(
                "(() => { const c = document.querySelector('[data-container=\"truck-1\"]');"
                " return c && c.querySelector('.badge').textContent === 'LOADED OK'; })()", 2.0)
            self.assertTrue(shown, "the estimate did not show within 2 s")
            self.assertLess(time.monotonic() - posted, 2.5)
            # Its detail: the status, the record in the table, and a drawn heightmap.
            browser.evaluate("document.querySelector('[data-container=\"truck-1\"]').click(); true")
            self.assertTrue(browser.wait_for(
                "document.querySelector('#recent tbody td:last-child') &&"
                " document.querySelector('#recent tbody td:last-child').textContent === 'browser-load-1'", 5))
            self.assertTrue(browser.wait_for(
                "document.getElementById('heightmap-caption').textContent.includes('cells')", 5))
            painted = browser.evaluate(
                "(() => { const c = document.getElementById('heightmap');"
                " const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
                " let n = 0; for (let i = 3; i < d.length; i += 4) n += d[i] > 0; return n; })()")
            self.assertGreater(painted, 10000)
            self.assertEqual(browser.evaluate("document.getElementById('detail-status').textContent"),
                             "LOADED OK")
            self.assertRegex(browser.evaluate("document.getElementById('facts').textContent"),
                             r"volume[\d.]+ m³ ± [\d.]+ (L|m³)")  # the 1-sigma beside it
            self.assertTrue(browser.evaluate(
                "document.getElementById('detail-warnings').classList.contains('hidden')"))
            os.makedirs(SCREENSHOTS, exist_ok=True)
            path = os.path.join(SCREENSHOTS, screenshot_name)
            browser.screenshot(path)
            self.assertGreater(os.path.getsize(path), 20000)
            # The warned bin's details: its capacity with the 1-sigma, the warning in full.
            browser.evaluate("document.querySelector('[data-container=\"bin-3\"]').click(); true")
            self.assertTrue(browser.wait_for(
                "document.getElementById('detail-title').textContent === 'Bin 3'", 5))
            shown = browser.evaluate("document.getElementById('detail-warnings').textContent")
            self.assertIn(warned["warnings"][0], shown)
            self.assertTrue(browser.evaluate(
                "document.getElementById('detail-warnings').offsetHeight > 0"))
            sigma_l = 1000 * warned["struckCapacityUncertaintyM3"]
            self.assertIn(f"± {sigma_l:.1f} L (1σ)",
                          browser.evaluate("document.getElementById('facts').textContent"))
            browser.screenshot(os.path.join(SCREENSHOTS, "warned-" + screenshot_name))
            self.assertEqual(browser.errors(), [])
        finally:
            browser.close()

    def test_the_site_sees_registrations_and_loads_live(self):
        with Server(args=["--workers", "2"]) as server:
            self.run_flow(server, "dashboard.png")

    def test_a_tablet_and_a_phone_see_the_whole_page_with_named_times(self):
        """At 1280, 900 (tablet) and 420 px (phone): nothing wider than the window, the colour
        bar's values, the target band named, the history's ends apart and the times' zone shown;
        a container registered again starts a new history."""
        with Server(args=["--workers", "2"]) as server:
            self.assertEqual(register(server, "truck-1", "Truck 1", 0.2)[0], 200)
            self.assertEqual(estimate(server, "truck-1", 0.15, "width-1")[0], 200)
            time.sleep(1.2)  # the history's ends a second apart
            self.assertEqual(estimate(server, "truck-1", 0.2, "width-2")[0], 200)
            for width in (1280, 900, 420):
                browser = Browser(width=width, height=1100, zone="Europe/Berlin")
                try:
                    # Headless windows are at least 500 px wide: the phone's width is emulated.
                    browser.call("Emulation.setDeviceMetricsOverride",
                                 {"width": width, "height": 1100, "deviceScaleFactor": 1,
                                  "mobile": width < 500}, session=True)
                    browser.call("Page.navigate", {"url": server.base_url + "/#truck-1"},
                                 session=True)
                    self.assertTrue(browser.wait_for(
                        "document.querySelectorAll('#recent tbody tr').length === 2 &&"
                        " document.getElementById('heightmap-ticks').children.length === 3", 10),
                        browser.errors())
                    self.assertEqual(browser.evaluate("window.innerWidth"), width)
                    self.assertLessEqual(
                        browser.evaluate("document.documentElement.scrollWidth"),
                        browser.evaluate("window.innerWidth"), f"overflows at {width} px")
                    ticks = browser.evaluate(
                        "[...document.getElementById('heightmap-ticks').children]"
                        ".map((t) => t.textContent)")
                    self.assertTrue(all(t.endswith(" cm") for t in ticks), ticks)
                    self.assertIn("target band (0.20 m³",
                                  browser.evaluate("document.getElementById('history-caption')"
                                                   ".textContent"))
                    first, last = browser.evaluate(
                        "document.getElementById('history').dataset.axis").split(" | ")
                    self.assertNotEqual(first, last.split(" ")[0])
                    self.assertIn("GMT+1", last)
                    self.assertEqual(browser.evaluate("document.getElementById('zone').value"),
                                     "Europe/Berlin")
                    shown = browser.evaluate("document.querySelector('#recent tbody td')"
                                             ".textContent")
                    self.assertRegex(shown, r"GMT\+1|CET")
                    os.makedirs(SCREENSHOTS, exist_ok=True)
                    browser.screenshot(os.path.join(SCREENSHOTS, f"dashboard-{width}px.png"))
                    self.assertEqual(browser.errors(), [])
                finally:
                    browser.close()
            # Registered again: its card and details start anew (the records stay, listed with
            # registrationId=-).
            self.assertEqual(register(server, "truck-1", "Truck 1", 0.2)[0], 200)
            browser = Browser()
            try:
                browser.call("Page.navigate", {"url": server.base_url + "/#truck-1"},
                             session=True)
                self.assertTrue(browser.wait_for(
                    "(() => { const s = document.getElementById('detail-status');"
                    " return s !== null && s.textContent === 'no loads yet' &&"
                    " document.querySelectorAll('#recent tbody tr').length === 0; })()", 10),
                    browser.errors())
            finally:
                browser.close()

    def test_the_shift_its_loads_and_downloads_at_three_widths(self):
        """The shift's strip (its totals as GetProduction has them), its truck loads with their
        passes against the target and the body scan's reconciliation, the alerts panel (an
        alert raised while the page is open appears), and the CSV downloads, at 1280, 900 and
        420 px."""
        with Server(args=["--workers", "2", "--site-time-zone", "Europe/Berlin"]) as server:
            self.assertEqual(register(server, "bucket-1", "Bucket 1", 0.5)[0], 200)
            self.assertEqual(register(server, "body-1", "Body 1", 0.25)[0], 200)
            status, load = server.rest("POST", "/v1/loads", {
                "loadId": "truck-7-load", "load": {"haulUnitId": "truck-7",
                                                   "bodyContainerId": "body-1",
                                                   "displayName": "Truck 7"}})
            self.assertEqual(status, 200, load)
            for i, fill in enumerate((0.10, 0.12)):
                scan = box_scene.encode_ply(box_scene.box_scan(fill, seed=60 + i))
                status, answer = server.rest("POST", "/v1/containers/bucket-1:estimate", {
                    "scan": cloud_scan(scan), "loadId": "truck-7-load"})
                self.assertEqual(status, 200, answer)
            body = box_scene.encode_ply(box_scene.box_scan(0.22, seed=70))
            status, answer = server.rest("POST", "/v1/containers/body-1:estimate", {
                "scan": cloud_scan(body), "loadId": "truck-7-load"})
            self.assertEqual(status, 200, answer)
            for width in (1280, 900, 420):
                browser = Browser(width=width, height=1100, zone="Europe/Berlin")
                try:
                    browser.call("Emulation.setDeviceMetricsOverride",
                                 {"width": width, "height": 1100, "deviceScaleFactor": 1,
                                  "mobile": width < 500}, session=True)
                    browser.call("Page.navigate", {"url": server.base_url + "/"}, session=True)
                    self.assertTrue(browser.wait_for(
                        "document.querySelectorAll('[data-load-id=\"truck-7-load\"] .pass')"
                        ".length === 2", 10), browser.errors())
                    if width == 1280:  # an alert raised while the page is open shows up live
                        self.raise_refusal_alert(server)
                    self.assertTrue(browser.wait_for(
                        "document.querySelectorAll('#alerts .alert-refused-scans').length === 1",
                        10), browser.errors())
                    self.assertIn("bucket-1: 1 scan refused in a row", browser.evaluate(
                        "document.querySelector('#alerts .alert-refused-scans').textContent"))
                    # The strip: the shift's passes (the body scan is no pass), its volume.
                    self.assertEqual(browser.evaluate(
                        "document.getElementById('shift-strip').dataset.passes"), "2")
                    shown = float(browser.evaluate(
                        "document.getElementById('shift-strip').dataset.volume"))
                    status, got = server.rest("GET", "/v1/loads/truck-7-load")
                    self.assertAlmostEqual(shown, got["volumeM3"], places=9)
                    reconcile = browser.evaluate(
                        "document.querySelector('[data-load-id=\"truck-7-load\"] .reconcile')"
                        ".textContent")
                    self.assertIn("body scan", reconcile)
                    self.assertIn(browser.evaluate("document.getElementById('shift-zone')"
                                                   ".textContent"), ("site time, Europe/Berlin",))
                    self.assertLessEqual(
                        browser.evaluate("document.documentElement.scrollWidth"),
                        browser.evaluate("window.innerWidth"), f"overflows at {width} px")
                    os.makedirs(SCREENSHOTS, exist_ok=True)
                    browser.screenshot(os.path.join(SCREENSHOTS, f"shift-{width}px.png"))
                    self.assertEqual(browser.errors(), [])
                finally:
                    browser.close()
            # The downloads the buttons make: the shift's CSV, fetched as the page does.
            browser = Browser()
            try:
                browser.call("Page.navigate", {"url": server.base_url + "/"}, session=True)
                self.assertTrue(browser.wait_for(
                    "document.getElementById('shift-select').value !== ''", 10), browser.errors())
                browser.evaluate(
                    "(() => { const s = document.getElementById('shift-select').value;"
                    " window.__csv = null;"
                    " fetch('/v1/loads:export').then((r) => r.text()).then((t) => { window.__csv = t; });"
                    " return true; })()")
                self.assertTrue(browser.wait_for("window.__csv !== null", 10))
                lines = browser.evaluate("window.__csv").strip().split("\r\n")
                self.assertTrue(lines[0].startswith("load_id,haul_unit_id"), lines[0])
                self.assertEqual(len(lines), 2)
                self.assertTrue(lines[1].startswith("truck-7-load,truck-7,body-1,Truck 7,"))
            finally:
                browser.close()

    @staticmethod
    def raise_refusal_alert(server):
        """bucket-1 alerts at its first refused scan; a scan contradicting its given pose is
        refused (FAILED_PRECONDITION)."""
        status, answer = server.rest("PATCH", "/v1/containers/bucket-1?updateMask=alert_rules",
                                     {"alertRules": {"refusedScansInARow": 1}})
        assert status == 200, answer
        scan = box_scene.encode_ply(box_scene.box_scan(0.05, seed=80))
        status, answer = server.rest("POST", "/v1/containers/bucket-1:estimate", {
            "scan": cloud_scan(scan), "containerPose": {
                "pose": {"positionM": {"x": 0.12}, "orientation": {"w": 1}},
                "positionSigmaM": 0.01, "orientationSigmaDeg": 0.5}})
        assert status == 400 and answer["details"][0]["reason"] == "FAILED_PRECONDITION", answer

    def test_with_token_auth(self):
        folder = tempfile.mkdtemp(prefix="soilvol-dash-auth-")
        tokens = os.path.join(folder, "tokens")
        with open(tokens, "w") as f:
            f.write(token_line("dashboard", "read,estimate,admin", TOKEN))
        os.chmod(tokens, 0o600)
        try:
            with Server(args=["--workers", "2", "--auth-tokens-file", tokens],
                        token=TOKEN) as server:
                # The page and its files need no token; the API does.
                status, _ = server.rest("GET", "/", headers={"Authorization": None})
                self.assertEqual(status, 200)
                status, _ = server.rest("GET", "/v1/containers", headers={"Authorization": None})
                self.assertEqual(status, 401)
                self.run_flow(server, "dashboard-auth.png", token=TOKEN)
        finally:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    unittest.main(verbosity=2)
