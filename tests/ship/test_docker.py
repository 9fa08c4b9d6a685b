"""Static checks of docker/ (there is no Docker engine on our machines): the Dockerfile and
compose.yaml must agree with the repository, the server and each other.

- every path COPY takes from the context exists and .dockerignore lets it in; what COPY takes
  from the build stage is made there (or installed by scripts/install-deps.sh);
- the build stage runs the scripts CI runs (install-deps.sh, build.sh);
- docker/runtime-packages.txt is exactly the Debian packages of the libraries the server and
  the CLI link (DT_NEEDED, through ldd and dpkg -S);
- ENV, EXPOSE, VOLUME, USER, HEALTHCHECK and ENTRYPOINT match the server's flags, and ENV is
  the secure setup (beyond loopback, TLS, tokens, a probe listener);
- the server refuses to start from the image's environment without its mounted files, naming
  the flag; with throwaway files (scripts/dev-secrets.sh) in their place it starts with the
  image's and compose's environment, the health check command passes against its probe
  listener, and a call without the token is refused (UNAUTHENTICATED, 401) while one with it
  works, through the CLI and over REST;
- compose's targets, ports, volumes (the secrets as read-only folders, where dev-secrets.sh
  writes them, gitignored), environment and test command (TLS, token) match the image.

Environment: SOILVOL_SERVER_BIN, SOILVOL_CLI_BIN (built binaries). Exit 77 (skip) when
python3-yaml is missing."""
import fnmatch
import glob
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import unittest

try:
    import yaml
except ImportError:
    print("skipped: python3-yaml is not installed", file=sys.stderr)
    sys.exit(77)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ship_common import (DevSecrets, ServerProcess, env_of, help_env,  # noqa: E402
                         parse_dockerfile, port_of, rest)

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DOCKERFILE = os.path.join(ROOT, "docker", "Dockerfile")
COMPOSE = os.path.join(ROOT, "docker", "compose.yaml")
SERVER_BIN = os.environ.get("SOILVOL_SERVER_BIN", os.path.join(ROOT, "build/server/soilvol-server"))
CLI_BIN = os.environ.get("SOILVOL_CLI_BIN", os.path.join(ROOT, "build/client/soilvol"))

# The variables of the files the operator mounts (docker/README.md), and the folders they go in.
SECRET_FILES = ("SOILVOL_TLS_CERT", "SOILVOL_TLS_KEY", "SOILVOL_AUTH_TOKENS_FILE")
SECRETS_MOUNT = "/etc/soilvol"

# Python modules the integration suite imports beyond the standard library, and the Debian
# package each comes from in the integration image. The generated stubs import google.protobuf.
PYTHON_PACKAGES = {"grpc": "python3-grpcio", "numpy": "python3-numpy",
                   "google": "python3-protobuf"}


def copy_sources(args):
    """(--from stage or None, [sources], destination) of a COPY's arguments."""
    words = shlex.split(args)
    flags = [w for w in words if w.startswith("--")]
    paths = [w for w in words if not w.startswith("--")]
    source_stage = next((f.split("=", 1)[1] for f in flags if f.startswith("--from=")), None)
    return source_stage, paths[:-1], paths[-1]


def dockerignore_admits(path, patterns):
    """True when .dockerignore's patterns (last match wins, ! re-includes) let `path` in;
    a pattern that matches a parent folder matches what is inside it."""
    admitted = True
    parts = path.split("/")
    prefixes = ["/".join(parts[:i]) for i in range(1, len(parts) + 1)]
    for pattern in patterns:
        negate = pattern.startswith("!")
        glob = pattern[1:] if negate else pattern
        glob = glob.rstrip("/")
        regex = fnmatch.translate(glob).replace(".*", "[^/]*")
        if glob.startswith("**/"):
            regex = "(?:.*/)?" + fnmatch.translate(glob[3:]).replace(".*", "[^/]*")
        if any(re.fullmatch(regex, prefix, re.DOTALL) for prefix in prefixes):
            admitted = negate
    return admitted


def dockerignore_patterns():
    with open(os.path.join(ROOT, ".dockerignore")) as f:
        return [line.strip() for line in f if line.strip() and not line.startswith("#")]


def install_deps_packages():
    with open(os.path.join(ROOT, "scripts", "install-deps.sh")) as f:
        text = f.read()
    block = re.search(r"packages=\((.*?)\)", text, re.DOTALL).group(1)
    return set(block.split())


def package_of(path):
    """The Debian package that owns a file (resolving /usr-merge symlinks), or None."""
    real = os.path.realpath(path)
    for candidate in (real, real[len("/usr"):] if real.startswith("/usr/") else None):
        if not candidate:
            continue
        done = subprocess.run(["dpkg", "-S", candidate], capture_output=True, text=True)
        if done.returncode == 0:
            return done.stdout.split(":", 1)[0].split(",")[0].strip()
    return None


def needed_packages(binaries):
    """Packages of the libraries the binaries link directly (DT_NEEDED)."""
    packages = set()
    for binary in binaries:
        needed = re.findall(r"\(NEEDED\)\s+Shared library: \[(.+?)\]",
                            subprocess.run(["readelf", "-d", binary], capture_output=True,
                                           text=True, check=True).stdout)
        resolved = dict(re.findall(r"^\s*(\S+) => (/\S+)", subprocess.run(
            ["ldd", binary], capture_output=True, text=True, check=True).stdout, re.MULTILINE))
        for library in needed:
            if library not in resolved:
                raise AssertionError(f"{binary}: ldd does not resolve {library}")
            package = package_of(resolved[library])
            if package is None:
                raise AssertionError(f"{resolved[library]} belongs to no Debian package")
            packages.add(package)
    return packages


def replay_copy(source, dest, into):
    """Docker's COPY of one context path to `dest` (relative to WORKDIR) under folder `into`:
    a folder's contents go into dest; a file goes to dest, or into it when dest ends in /."""
    path = os.path.join(ROOT, source)
    target = os.path.normpath(os.path.join(into, dest))
    if os.path.isdir(path):
        shutil.copytree(path, target, dirs_exist_ok=True)
        return
    if dest.endswith("/") or dest in (".", "./"):
        target = os.path.join(target, os.path.basename(source))
    os.makedirs(os.path.dirname(target), exist_ok=True)
    shutil.copy(path, target)


class Dockerfile(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.stages = dict(parse_dockerfile(DOCKERFILE))
        cls.server_env = help_env(SERVER_BIN)
        cls.runtime = cls.stages["runtime"]
        cls.runtime_env = env_of(cls.runtime)

    def instructions(self, stage, name):
        return [args for instruction, args in self.stages[stage] if instruction == name]

    def test_stages(self):
        self.assertEqual(list(self.stages), ["(global)", "build", "runtime", "integration"])
        self.assertRegex(self.instructions("build", "FROM")[0], r"^debian:\$\{DEBIAN_RELEASE\}$")
        self.assertEqual(self.instructions("runtime", "FROM"), ["debian:${DEBIAN_RELEASE}-slim"])
        self.assertEqual(self.instructions("integration", "FROM"), ["runtime"])
        self.assertEqual(self.instructions("(global)", "ARG"), ["DEBIAN_RELEASE=bookworm"])

    def test_build_stage_runs_the_ci_scripts(self):
        runs = " ".join(self.instructions("build", "RUN"))
        self.assertIn("scripts/install-deps.sh", runs)
        self.assertIn("scripts/build.sh", runs)

    def test_context_copies_exist_and_pass_dockerignore(self):
        patterns = dockerignore_patterns()
        copies = 0
        for stage, instructions in self.stages.items():
            for instruction, args in instructions:
                if instruction not in ("COPY", "ADD"):
                    continue
                self.assertEqual(instruction, "COPY", f"{stage}: use COPY, not ADD")
                source_stage, sources, _ = copy_sources(args)
                if source_stage is not None:
                    continue
                for source in sources:
                    copies += 1
                    path = os.path.join(ROOT, source)
                    self.assertTrue(os.path.exists(path), f"{stage}: COPY {source}: no such path")
                    rel = os.path.relpath(path, ROOT)
                    self.assertTrue(dockerignore_admits(rel, patterns),
                                    f"{stage}: COPY {source} is excluded by .dockerignore")
                    if os.path.isdir(path):
                        for dirpath, _, files in os.walk(path):
                            for name in files:
                                if name.endswith(".pyc"):
                                    continue
                                inner = os.path.relpath(os.path.join(dirpath, name), ROOT)
                                self.assertTrue(dockerignore_admits(inner, patterns),
                                                f".dockerignore drops {inner}")
        self.assertGreater(copies, 5)

    def test_dockerignore_keeps_out_build_trees_and_data(self):
        patterns = dockerignore_patterns()
        for path in ("build/server/soilvol-server", "data/containers/a.entry", ".git/HEAD",
                     "README.md", "bench/main.cpp", "tests/integration/__pycache__/x.pyc",
                     "docker/secrets/tls/tls.key", "docker/secrets/admin.token"):
            self.assertFalse(dockerignore_admits(path, patterns), path)

    def test_copies_from_the_build_stage_are_made_there(self):
        build_runs = " ".join(self.instructions("build", "RUN"))
        installed = install_deps_packages()
        for stage in ("runtime", "integration"):
            for args in self.instructions(stage, "COPY"):
                source_stage, sources, _ = copy_sources(args)
                if source_stage is None:
                    continue
                self.assertEqual(source_stage, "build")
                for source in sources:
                    if source.startswith("/out/"):
                        made = re.search(re.escape(source.rstrip("/")) + r"\b", build_runs)
                        self.assertTrue(made, f"{stage}: {source} is not made in the build stage")
                        continue
                    matches = sorted(glob.glob(source))
                    self.assertTrue(matches, f"{stage}: {source} matches nothing here")
                    package = package_of(matches[0])
                    self.assertIn(package, installed,
                                  f"{source} comes from {package}, not in install-deps.sh")

    @unittest.skipUnless(shutil.which("cmake"), "needs cmake")
    def test_build_stage_sources_configure(self):
        """The build stage's COPYs, replayed into an empty folder, hold a project that CMake
        configures with the flags of its build.sh call (a file it forgot fails here)."""
        with tempfile.TemporaryDirectory(prefix="soilvol-docker-src-") as src:
            for args in self.instructions("build", "COPY"):
                _, sources, dest = copy_sources(args)
                for source in sources:
                    replay_copy(source, dest, src)
            build_call = next(r for r in self.instructions("build", "RUN") if "build.sh" in r)
            flags = re.findall(r"-D\w+=\w+", build_call)
            self.assertIn("-DSOILVOL_BUILD_TESTS=OFF", flags)
            build = os.path.join(src, "_build")
            done = subprocess.run(["cmake", "-S", src, "-B", build, *flags],
                                  capture_output=True, text=True, timeout=300)
            self.assertEqual(done.returncode, 0, done.stdout[-3000:] + done.stderr[-3000:])
            # The targets whose outputs the stage installs into /out.
            targets = subprocess.run(["cmake", "--build", build, "--target", "help"],
                                     capture_output=True, text=True, timeout=60).stdout
            for target in ("soilvol-server", "soilvol", "soilvol_proto_python"):
                self.assertRegex(targets, rf"(?m)^(\.\.\. )?{target}(:| |$)", target)

    def test_built_binaries_are_the_cmake_targets(self):
        build_runs = " ".join(self.instructions("build", "RUN"))
        self.assertIn("/build/server/soilvol-server", build_runs)
        self.assertIn("/build/client/soilvol ", build_runs)
        self.assertTrue(SERVER_BIN.endswith("server/soilvol-server"), SERVER_BIN)
        self.assertTrue(CLI_BIN.endswith("client/soilvol"), CLI_BIN)

    @unittest.skipUnless(shutil.which("dpkg") and shutil.which("readelf"), "needs dpkg, readelf")
    def test_runtime_packages_are_exactly_what_the_binaries_link(self):
        with open(os.path.join(ROOT, "docker", "runtime-packages.txt")) as f:
            listed = {line.strip() for line in f if line.strip()}
        needed = needed_packages([SERVER_BIN, CLI_BIN])
        if {"libasan8", "libubsan1"} & needed:
            self.skipTest("sanitizer build: it links the sanitizer runtimes; the image ships "
                          "the Release binaries")
        self.assertEqual(sorted(needed - listed), [], "linked but not in runtime-packages.txt")
        self.assertEqual(sorted(listed - needed), [], "in runtime-packages.txt but not linked")

    def test_environment_and_ports_match_the_server(self):
        for key in self.runtime_env:
            self.assertIn(key, self.server_env, f"ENV {key} is not a server variable")
        grpc_port = port_of(self.runtime_env["SOILVOL_GRPC_ADDRESS"])
        http_port = port_of(self.runtime_env["SOILVOL_HTTP_ADDRESS"])
        probe_port = port_of(self.runtime_env["SOILVOL_PROBE_ADDRESS"])
        self.assertEqual(grpc_port, port_of(self.server_env["SOILVOL_GRPC_ADDRESS"]))
        self.assertEqual(http_port, port_of(self.server_env["SOILVOL_HTTP_ADDRESS"]))
        exposed = {int(p) for args in self.instructions("runtime", "EXPOSE") for p in args.split()}
        self.assertEqual(exposed, {grpc_port, http_port, probe_port})
        self.assertEqual(self.instructions("runtime", "VOLUME"),
                         [f'["{self.runtime_env["SOILVOL_DATA_DIR"]}"]'])

    def test_environment_is_the_secure_setup(self):
        env = self.runtime_env
        for key in ("SOILVOL_GRPC_ADDRESS", "SOILVOL_HTTP_ADDRESS", "SOILVOL_PROBE_ADDRESS"):
            self.assertTrue(env[key].startswith("0.0.0.0:"), f"{key}: other containers reach it")
        for key in SECRET_FILES:
            self.assertTrue(env[key].startswith(SECRETS_MOUNT + "/"), key)
        self.assertEqual(os.path.dirname(env["SOILVOL_TLS_CERT"]),
                         os.path.dirname(env["SOILVOL_TLS_KEY"]), "one folder: one Secret")
        # cert-manager's and `kubectl create secret tls`'s file names.
        self.assertEqual(os.path.basename(env["SOILVOL_TLS_CERT"]), "tls.crt")
        self.assertEqual(os.path.basename(env["SOILVOL_TLS_KEY"]), "tls.key")
        self.assertNotIn("SOILVOL_ALLOW_UNAUTHENTICATED", env)
        self.assertIn(env.get("SOILVOL_METRICS", "open"), ("auth", "off"),
                      "/metrics on the REST port without a token")

    def test_runs_as_the_user_it_creates(self):
        runs = " ".join(self.instructions("runtime", "RUN"))
        uid = re.search(r"useradd [^&]*--uid (\d+)", runs).group(1)
        gid = re.search(r"groupadd [^&]*--gid (\d+)", runs).group(1)
        self.assertNotEqual(uid, "0")
        for stage in ("runtime", "integration"):
            self.assertEqual(self.instructions(stage, "USER")[-1], f"{uid}:{gid}",
                             f"{stage} must end as the non-root user")
        self.assertRegex(runs, r"chown soilvol:soilvol " + re.escape(
            self.runtime_env["SOILVOL_DATA_DIR"]))

    def health_check_argv(self):
        check = self.instructions("runtime", "HEALTHCHECK")
        self.assertEqual(len(check), 1)
        return yaml.safe_load(re.search(r"CMD (\[.*\])$", check[0]).group(1))

    def test_entrypoint_and_health_check(self):
        self.assertEqual(self.instructions("runtime", "ENTRYPOINT"), ['["soilvol-server"]'])
        argv = self.health_check_argv()
        self.assertEqual(argv[0], "soilvol")
        # The probe listener: no TLS, no token; the gRPC and REST ports would need both.
        self.assertEqual(argv[-3:-1], ["health", "--probe"])
        self.assertEqual(argv[-1],
                         f"127.0.0.1:{port_of(self.runtime_env['SOILVOL_PROBE_ADDRESS'])}")
        self.assertEqual(self.instructions("integration", "HEALTHCHECK"), ["NONE"])

    def cli(self, *args, env=None):
        return subprocess.run([CLI_BIN, *args], env=dict(os.environ, **(env or {})),
                              capture_output=True, text=True, timeout=30)

    def test_server_refuses_to_start_without_credentials(self):
        """The image's addresses with the secret files' variables unset: refused before it
        listens, with the flag to give named."""
        env = {k: v for k, v in self.runtime_env.items() if k not in SECRET_FILES}
        with tempfile.TemporaryDirectory(prefix="soilvol-ship-") as data:
            full = {k: v for k, v in os.environ.items() if not k.startswith("SOILVOL_")}
            full.update(env, SOILVOL_DATA_DIR=data,
                        SOILVOL_GRPC_ADDRESS="0.0.0.0:0", SOILVOL_HTTP_ADDRESS="0.0.0.0:0",
                        SOILVOL_PROBE_ADDRESS="127.0.0.1:0")
            done = subprocess.run([SERVER_BIN], env=full, capture_output=True, text=True,
                                  timeout=30)
        self.assertEqual(done.returncode, 2, done.stderr)
        self.assertIn("--auth-tokens-file", done.stderr)

    @unittest.skipUnless(shutil.which("openssl"), "needs the openssl CLI")
    def test_server_refuses_to_start_without_the_mounted_files(self):
        """The image's environment with a folder missing in /etc/soilvol: the server stops
        with the flag of the missing file named (docker/README.md)."""
        secrets = DevSecrets()
        try:
            for missing, flag in (("auth", "--auth-tokens-file"), ("tls", "--tls-cert")):
                with self.subTest(missing=missing):
                    mounts = {f"{SECRETS_MOUNT}/tls": secrets.tls,
                              f"{SECRETS_MOUNT}/auth": secrets.auth}
                    mounts[f"{SECRETS_MOUNT}/{missing}"] = os.path.join(secrets.dir, "absent")
                    server = ServerProcess(SERVER_BIN, secrets.mounted(self.runtime_env, mounts))
                    code, log = server.wait_exit(30)
                    self.assertNotEqual(code, 0, log)
                    self.assertIn(flag, log)
        finally:
            secrets.close()

    @unittest.skipUnless(shutil.which("openssl"), "needs the openssl CLI")
    def test_server_starts_with_the_image_environment_and_passes_its_health_check(self):
        """The image's and compose's environment, dev-secrets.sh's files in place of the
        mounted ones: TLS and tokens on, the health check passes, the token is asked for."""
        with open(COMPOSE) as f:
            compose_env = yaml.safe_load(f)["services"]["server"].get("environment", {})
        env = dict(self.runtime_env, **{k: str(v) for k, v in compose_env.items()})
        secrets = DevSecrets()
        server = ServerProcess(SERVER_BIN, secrets.mounted(env, {
            f"{SECRETS_MOUNT}/tls": secrets.tls, f"{SECRETS_MOUNT}/auth": secrets.auth}))
        try:
            started = server.wait_listening(60)
            self.assertEqual((started["tls"], started["auth"]), ("on", "tokens"))
            argv = self.health_check_argv()
            argv[-1] = f"127.0.0.1:{started['probe_port']}"
            done = self.cli(*argv[1:])
            self.assertEqual(done.returncode, 0, done.stderr)
            self.assertIn("SERVING", done.stdout)
            self.check_credentials_are_asked_for(started, secrets)
        finally:
            code = server.stop()
            secrets.close()
        self.assertEqual(code, 0, "".join(server.log))

    def check_credentials_are_asked_for(self, started, secrets):
        target = ["--server", f"127.0.0.1:{started['grpc_port']}", "--tls-ca", secrets.ca]
        refused = self.cli(*target, "containers", "list")
        self.assertNotEqual(refused.returncode, 0, refused.stdout)
        self.assertIn("UNAUTHENTICATED", refused.stderr)
        allowed = self.cli(*target, "--token-file", secrets.token_file, "containers", "list")
        self.assertEqual(allowed.returncode, 0, allowed.stderr)
        # The CLI's variables do the same (the integration suite's CLI tests rely on them).
        allowed = self.cli("--server", f"127.0.0.1:{started['grpc_port']}", "containers", "list",
                           env={"SOILVOL_TLS_CA": secrets.ca,
                                "SOILVOL_TOKEN_FILE": secrets.token_file})
        self.assertEqual(allowed.returncode, 0, allowed.stderr)
        https = f"https://127.0.0.1:{started['http_port']}"
        self.assertEqual(rest(https + "/v1/containers", secrets.ca), 401)
        self.assertEqual(rest(https + "/v1/containers", secrets.ca, secrets.token), 200)
        metrics_open = self.runtime_env.get("SOILVOL_METRICS", "open") == "open"
        self.assertEqual(rest(https + "/metrics", secrets.ca), 200 if metrics_open else 401)
        self.assertEqual(rest(f"http://127.0.0.1:{started['probe_port']}/metrics"), 200)

    def test_integration_image_has_what_the_suite_imports(self):
        suite = os.path.join(ROOT, "tests", "integration")
        local = {f[:-3] for f in os.listdir(suite) if f.endswith(".py")} | {"soilvol"}
        imported = set()
        for name in os.listdir(suite):
            if name.endswith(".py"):
                with open(os.path.join(suite, name)) as f:
                    imported |= set(re.findall(r"^\s*(?:import|from)\s+(\w+)", f.read(), re.M))
        third_party = imported - set(sys.stdlib_module_names) - local
        self.assertTrue(third_party <= set(PYTHON_PACKAGES),
                        f"imports without a known Debian package: {third_party - set(PYTHON_PACKAGES)}")
        runs = " ".join(self.instructions("integration", "RUN"))
        for package in set(PYTHON_PACKAGES.values()):
            self.assertIn(package, runs.split())
        env = env_of(self.stages["integration"])
        copied = {dest.rstrip("/"): sources for _, sources, dest in
                  (copy_sources(a) for a in self.instructions("integration", "COPY"))}
        self.assertIn(env["SOILVOL_PROTO_PYTHON"], copied)
        self.assertEqual(env["SOILVOL_CLI_BIN"], "/usr/local/bin/soilvol")
        entry = yaml.safe_load(self.instructions("integration", "ENTRYPOINT")[0])
        self.assertEqual(entry[0], "python3")
        script = entry[1]
        suite_dest = next(d for d, s in copied.items() if s == ["tests/integration/"])
        self.assertEqual(script, f"{suite_dest}/run_suite.py")


def volume_mounts(service):
    """{target: (type, source, read_only, create_host_path)} of a compose service's volumes,
    short ("source:target[:ro]") or long syntax."""
    mounts = {}
    for volume in service.get("volumes", []):
        if isinstance(volume, str):
            parts = volume.split(":")
            kind = "bind" if parts[0].startswith((".", "/")) else "volume"
            mounts[parts[1]] = (kind, parts[0], parts[2:] == ["ro"], True)
        else:
            mounts[volume["target"]] = (volume["type"], volume["source"],
                                        volume.get("read_only", False),
                                        volume.get("bind", {}).get("create_host_path", True))
    return mounts


class Compose(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        with open(COMPOSE) as f:
            cls.compose = yaml.safe_load(f)
        cls.stages = dict(parse_dockerfile(DOCKERFILE))
        cls.runtime_env = env_of(cls.stages["runtime"])
        cls.server_env = help_env(SERVER_BIN)

    def host_path(self, source):
        return os.path.normpath(os.path.join(os.path.dirname(COMPOSE), source))

    def test_builds_resolve_to_the_dockerfile_stages(self):
        for name, service in self.compose["services"].items():
            build = service["build"]
            context = self.host_path(build["context"])
            self.assertEqual(context, ROOT, name)
            self.assertEqual(os.path.join(context, build["dockerfile"]), DOCKERFILE, name)
            self.assertIn(build["target"], self.stages, name)

    def test_server_ports_volume_and_environment(self):
        server = self.compose["services"]["server"]
        self.assertEqual(server["build"]["target"], "runtime")
        for port in server["ports"]:
            self.assertTrue(port.startswith("127.0.0.1:"), f"{port}: published beyond loopback")
        published = {int(p.rsplit(":", 1)[1]) for p in server["ports"]}
        exposed = {int(p) for _, args in self.stages["runtime"] if _ == "EXPOSE"
                   for p in args.split()}
        self.assertEqual(published, exposed)
        data = volume_mounts(server)[self.runtime_env["SOILVOL_DATA_DIR"]]
        self.assertEqual(data[0], "volume")
        self.assertIn(data[1], self.compose["volumes"])
        for key in server.get("environment", {}):
            self.assertIn(key, self.server_env)
        grace = float(server.get("environment", {}).get("SOILVOL_SHUTDOWN_GRACE_S", 10))
        self.assertGreater(float(server["stop_grace_period"].rstrip("s")), grace)

    @unittest.skipUnless(shutil.which("openssl"), "needs the openssl CLI")
    def test_server_mounts_the_dev_secrets_where_the_image_reads_them(self):
        """Each secret file's folder is a read-only bind mount of a folder that
        scripts/dev-secrets.sh fills with that file; a missing one stops compose."""
        mounts = volume_mounts(self.compose["services"]["server"])
        secrets_dir = os.path.join(ROOT, "docker", "secrets")
        made = DevSecrets()
        try:
            for key in SECRET_FILES:
                folder, name = os.path.split(self.runtime_env[key])
                self.assertIn(folder, mounts, f"{key}: {folder} is not mounted")
                kind, source, read_only, create = mounts[folder]
                self.assertEqual((kind, read_only, create), ("bind", True, False), folder)
                relative = os.path.relpath(self.host_path(source), secrets_dir)
                self.assertFalse(relative.startswith(".."), f"{source} is outside docker/secrets")
                self.assertTrue(os.path.isfile(os.path.join(made.dir, relative, name)),
                                f"dev-secrets.sh writes no {relative}/{name}")
        finally:
            made.close()

    def test_secrets_stay_out_of_git_and_the_build_context(self):
        self.assertFalse(dockerignore_admits("docker/secrets/tls/tls.key", dockerignore_patterns()))
        if not shutil.which("git") or not os.path.isdir(os.path.join(ROOT, ".git")):
            self.skipTest("not a git checkout")
        for path in ("docker/secrets/tls/tls.key", "docker/secrets/admin.token"):
            ignored = subprocess.run(["git", "-C", ROOT, "check-ignore", "-q", path])
            self.assertEqual(ignored.returncode, 0, f"{path} is not gitignored")

    def test_integration_targets_the_server_over_tls_with_the_token(self):
        test = self.compose["services"]["integration"]
        self.assertEqual(test["build"]["target"], "integration")
        self.assertEqual(test["depends_on"]["server"]["condition"], "service_healthy")
        args = test["command"]
        # The image's default command is the same.
        cmd = yaml.safe_load(next(a for k, a in self.stages["integration"] if k == "CMD"))
        self.assertEqual(cmd, args)
        value = {flag: args[args.index(flag) + 1]
                 for flag in ("--grpc", "--http", "--tls-ca", "--token-file")}
        self.assertEqual(value["--grpc"],
                         f"server:{port_of(self.runtime_env['SOILVOL_GRPC_ADDRESS'])}")
        self.assertEqual(value["--http"],
                         f"https://server:{port_of(self.runtime_env['SOILVOL_HTTP_ADDRESS'])}")
        # The CA and the token come from what dev-secrets.sh writes, and nothing else: the
        # server's key stays in the server's container.
        mounts = volume_mounts(test)
        secrets_dir = os.path.join(ROOT, "docker", "secrets")
        sources = {}
        for flag, made in (("--tls-ca", "tls/ca.crt"), ("--token-file", "admin.token")):
            kind, source, read_only, create = mounts[value[flag]]
            self.assertEqual((kind, read_only, create), ("bind", True, False), flag)
            sources[flag] = os.path.relpath(self.host_path(source), secrets_dir)
            self.assertEqual(sources[flag], made, flag)
        self.assertEqual(len(mounts), 2, "the integration container mounts only CA and token")
        runner = subprocess.run([sys.executable, os.path.join(ROOT, "tests", "integration",
                                                              "run_suite.py"), "--help"],
                                capture_output=True, text=True, timeout=30)
        self.assertEqual(runner.returncode, 0, runner.stderr)
        for flag in value:
            self.assertIn(flag, runner.stdout)


if __name__ == "__main__":
    unittest.main(verbosity=2)
