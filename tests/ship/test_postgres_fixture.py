"""The README's test command from a clone anywhere (issue 28 item 6): the records tests' PostgreSQL
fixture (scripts/test-postgres.sh) must start, answer and stop when the clone lies in a
directory other users cannot enter (a mode-700 mkdtemp, as /root is), run as root (the server
then runs as the postgres user) or not. Skipped (77) without Debian's PostgreSQL server."""
import glob
import os
import shutil
import subprocess
import sys
import tempfile
import unittest
import urllib.parse

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SCRIPT = os.path.join(ROOT, "scripts", "test-postgres.sh")


def psql():
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/psql"))
    return found[-1] if found else shutil.which("psql")


class PostgresFixture(unittest.TestCase):
    def test_starts_answers_and_stops_from_a_closed_directory(self):
        closed = tempfile.mkdtemp(prefix="soilvol-closed-")
        os.chmod(closed, 0o700)
        data = os.path.join(closed, "clone", "build", "pg")
        try:
            url = subprocess.run([SCRIPT, "start", data], capture_output=True, text=True,
                                 timeout=120, check=True).stdout.strip()
            query = urllib.parse.parse_qs(urllib.parse.urlparse(url).query)
            host = query["host"][0]
            try:
                answer = subprocess.run(
                    [psql(), "-h", host, "-U", "soilvol", "-d", "postgres", "-tAc", "select 41+1"],
                    capture_output=True, text=True, timeout=60)
                self.assertEqual(answer.returncode, 0, answer.stderr)
                self.assertEqual(answer.stdout.strip(), "42")
            finally:
                subprocess.run([SCRIPT, "stop", data], timeout=120, check=True)
            self.assertFalse(os.path.exists(os.path.join(host, "data", "postmaster.pid")),
                             "the server did not stop")
            if host != data:  # relocated for the postgres user: under /tmp, named after DIR
                self.assertEqual(os.geteuid(), 0)
                self.assertTrue(host.startswith("/tmp/soilvol-pg-"), host)
                shutil.rmtree(host)
        finally:
            shutil.rmtree(closed, ignore_errors=True)


if __name__ == "__main__":
    if not glob.glob("/usr/lib/postgresql/*/bin/pg_ctl"):
        print("no PostgreSQL server installed: skipped")
        sys.exit(77)
    unittest.main(verbosity=2)
