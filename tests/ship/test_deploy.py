#!/usr/bin/env python3
"""deploy/ agrees with the server: its flags, ports, probes, secrets, data dir, user, shutdown.

Reads the resources listed in deploy/kustomization.yaml (selectors and pod labels are written out
there, so no rendering is needed) and runs the server binary with the ConfigMap as its
environment, throwaway secrets (scripts/dev-secrets.sh) standing in for the mounted Secrets: the
probes' paths answer on the probe port, TLS and the token are asked for on the others.
SOILVOL_SERVER_BIN: the server (default /tmp/build/server/soilvol-server); SOILVOL_DEPLOY_DIR:
the manifests (default deploy/ of this checkout). Exit 77 = skipped (no python3-yaml).
"""
import importlib.util
import os
import re
import shutil
import sys
import unittest
from pathlib import Path

try:
    import yaml
except ImportError:
    print("skipped: python3-yaml is not installed (apt-get install python3-yaml)")
    sys.exit(77)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ship_common import (DevSecrets, ServerProcess, help_env, is_loopback,  # noqa: E402
                         parse_dockerfile, port_of, rest)

ROOT = Path(__file__).resolve().parents[2]
DEPLOY_DIR = Path(os.environ.get("SOILVOL_DEPLOY_DIR", ROOT / "deploy"))
DOCKERFILE = ROOT / "docker" / "Dockerfile"
SERVER_BIN = os.environ.get("SOILVOL_SERVER_BIN", "/tmp/build/server/soilvol-server")

IMAGE_UID = 10001  # the image's user soilvol (docker/README.md, the Dockerfile contract)
# What the probe listener serves (server/http_gateway.cpp): liveness, readiness, metrics.
PROBE_PATHS = {"/healthz", "/readyz", "/metrics"}
# The keys of each Secret: a kubernetes.io/tls Secret as cert-manager writes it (ca.crt with CA,
# Vault and self-signed issuers), and the token file (deploy/README.md).
SECRET_KEYS = {"soilvol-tls": {"tls.crt", "tls.key", "ca.crt"}, "soilvol-auth": {"tokens"}}
# The ConfigMap's variables that name files in mounted Secrets.
SECRET_FILES = ("SOILVOL_TLS_CERT", "SOILVOL_TLS_KEY", "SOILVOL_TLS_CLIENT_CA",
                "SOILVOL_AUTH_TOKENS_FILE")


def load_resources():
    kustomization = yaml.safe_load((DEPLOY_DIR / "kustomization.yaml").read_text())
    resources = []
    for name in kustomization["resources"]:
        text = (DEPLOY_DIR / name).read_text()
        resources += [doc for doc in yaml.safe_load_all(text) if doc is not None]
    return resources


def only(resources, kind, name=None):
    found = [r for r in resources
             if r["kind"] == kind and (name is None or r["metadata"]["name"] == name)]
    if len(found) != 1:
        raise AssertionError(f"expected one {kind} {name or ''}, found {len(found)}")
    return found[0]


def cpu_cores(quantity):
    text = str(quantity)
    return int(text[:-1]) / 1000 if text.endswith("m") else float(text)


def prestop_seconds(container):
    pre_stop = container.get("lifecycle", {}).get("preStop", {})
    if "sleep" in pre_stop:
        return pre_stop["sleep"]["seconds"]
    command = pre_stop.get("exec", {}).get("command", [])
    if len(command) == 2 and command[0] in ("sleep", "/bin/sleep"):
        return float(command[1])
    raise AssertionError(f"no preStop delay (sleep action or exec sleep N): {pre_stop}")


def dockerfile_server_stage():
    """Instructions (keyword, argument) of the last stage whose ENTRYPOINT is soilvol-server."""
    servers = [stage for _, stage in parse_dockerfile(DOCKERFILE)
               if any(k == "ENTRYPOINT" and "soilvol-server" in a for k, a in stage)]
    if not servers:
        raise AssertionError(f"{DOCKERFILE}: no stage has ENTRYPOINT soilvol-server")
    return servers[-1]


def grpc_code(port, method, ca, token=None):
    """The status code name of a gRPC call with an empty request over TLS (trusting `ca`),
    with `token` as a bearer token when given; SERVING/NOT_SERVING for a health check."""
    import grpc
    credentials = grpc.ssl_channel_credentials(Path(ca).read_bytes())
    options = [("grpc.enable_http_proxy", 0)]
    metadata = [("authorization", f"Bearer {token}")] if token else []
    with grpc.secure_channel(f"127.0.0.1:{port}", credentials, options=options) as channel:
        call = channel.unary_unary(method)
        try:
            response = call(b"", timeout=10, metadata=metadata)
        except grpc.RpcError as e:
            return e.code().name
    if method.endswith("Health/Check"):  # HealthCheckResponse{status = 1}: 0x08 then the enum
        return "SERVING" if response == b"\x08\x01" else "NOT_SERVING"
    return "OK"


def probe_port_of(container, probe):
    """The container port number a probe's httpGet asks (by name or number)."""
    port = container[probe]["httpGet"]["port"]
    named = {p["name"]: p["containerPort"] for p in container["ports"]}
    return named.get(port, port)


class Manifests(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.resources = load_resources()
        cls.config = only(cls.resources, "ConfigMap")["data"]
        cls.deployment = only(cls.resources, "Deployment")
        cls.pod = cls.deployment["spec"]["template"]
        containers = {c["name"]: c for c in cls.pod["spec"]["containers"]}
        cls.container = containers["server"]
        cls.grpc_port = port_of(cls.config["SOILVOL_GRPC_ADDRESS"])
        cls.http_port = port_of(cls.config["SOILVOL_HTTP_ADDRESS"])
        cls.probe_port = port_of(cls.config["SOILVOL_PROBE_ADDRESS"])
        cls.volumes = {v["name"]: v for v in cls.pod["spec"]["volumes"]}

    def assertSelects(self, selector, what):
        labels = self.pod["metadata"]["labels"]
        self.assertTrue(selector, f"{what}: empty selector")
        for key, value in selector.items():
            self.assertEqual(labels.get(key), value, f"{what} selects {key}={value}; pod labels "
                             f"are {labels}")

    def test_configmap_holds_every_server_flag_and_nothing_else(self):
        flags = set(help_env(SERVER_BIN))
        self.assertIn("SOILVOL_WORKERS", flags, "--help output changed: (Env:...) not found")
        self.assertEqual(set(self.config) - flags, set(), "keys the server does not read")
        self.assertEqual(flags - set(self.config), set(), "server flags missing from ConfigMap")
        for key, value in self.config.items():
            self.assertIsInstance(value, str, f"{key}: ConfigMap values are strings")

    def test_pod_reads_the_configmap(self):
        sources = [e["configMapRef"]["name"] for e in self.container.get("envFrom", [])]
        self.assertEqual(sources, [only(self.resources, "ConfigMap")["metadata"]["name"]])
        # Service links would put SOILVOL_SERVICE_HOST, SOILVOL_PORT_... beside the flags.
        self.assertIs(self.pod["spec"].get("enableServiceLinks"), False)

    def test_ports_match_listen_addresses(self):
        ports = {p["name"]: p["containerPort"] for p in self.container["ports"]}
        self.assertEqual(ports, {"grpc": self.grpc_port, "http": self.http_port,
                                 "probe": self.probe_port})
        annotations = self.pod["metadata"]["annotations"]
        # Prometheus scrapes the probe port: /metrics there needs no token.
        self.assertEqual(annotations["prometheus.io/port"], str(self.probe_port))
        self.assertIn(annotations["prometheus.io/path"], PROBE_PATHS)
        self.assertNotEqual(self.config["SOILVOL_METRICS"], "off")
        for service in [r for r in self.resources if r["kind"] == "Service"]:
            for port in service["spec"]["ports"]:
                # Health and metrics without credentials stay off the Services.
                self.assertIn(port["name"], ("grpc", "http"), service["metadata"]["name"])
                target = port.get("targetPort", port["port"])
                target = ports.get(target, target)  # a name resolves to the container port
                self.assertEqual(target, ports[port["name"]],
                                 f"Service {service['metadata']['name']} port {port['name']}")
                # TLS on both: h2c (cleartext HTTP/2) and http would misdirect meshes.
                self.assertIn(port.get("appProtocol"), (None, "https"),
                              f"Service {service['metadata']['name']} port {port['name']}")

    def test_probes_use_the_probe_listener(self):
        """HTTP probes on the plain-HTTP probe port (the others speak TLS only and ask for
        tokens): liveness on /healthz, readiness on /readyz."""
        paths = {"startupProbe": "/healthz", "livenessProbe": "/healthz",
                 "readinessProbe": "/readyz"}
        for probe, path in paths.items():
            self.assertNotIn("grpc", self.container[probe], probe)
            get = self.container[probe]["httpGet"]
            self.assertEqual(get["path"], path, probe)
            self.assertEqual(probe_port_of(self.container, probe), self.probe_port, probe)
            self.assertIn(get.get("scheme", "HTTP"), ("HTTP",), probe)

    def test_configuration_asks_for_credentials(self):
        config = self.config
        for key in ("SOILVOL_GRPC_ADDRESS", "SOILVOL_HTTP_ADDRESS", "SOILVOL_PROBE_ADDRESS"):
            self.assertFalse(is_loopback(config[key]), f"{key}: the kubelet and Services reach it")
        self.assertEqual(config["SOILVOL_ALLOW_UNAUTHENTICATED"], "false")
        self.assertTrue(config["SOILVOL_TLS_CERT"] and config["SOILVOL_TLS_KEY"], "TLS")
        self.assertTrue(config["SOILVOL_AUTH_TOKENS_FILE"] or config["SOILVOL_TLS_CLIENT_CA"],
                        "no credentials are asked for")
        self.assertEqual(config["SOILVOL_METRICS"], "auth", "/metrics on REST without a token")

    def secret_mount(self, path):
        """(volumeMount, Secret name) of the mounted Secret that holds file `path`."""
        folder, _ = os.path.split(path)
        mounts = [m for m in self.container["volumeMounts"] if m["mountPath"] == folder]
        self.assertEqual(len(mounts), 1, f"{path}: no mount at {folder}")
        volume = self.volumes[mounts[0]["name"]]
        self.assertIn("secret", volume, f"{path}: {mounts[0]['name']} is not a Secret")
        return mounts[0], volume["secret"]["secretName"]

    def test_secrets_are_mounted_as_folders_without_subpath(self):
        """Every file the ConfigMap names lies in a Secret mounted read-only as a whole folder:
        a subPath mount never sees the kubelet's atomic swaps, so rotations would not reach
        the server."""
        used = set()
        for key in SECRET_FILES:
            if not self.config[key]:
                continue
            mount, secret = self.secret_mount(self.config[key])
            used.add(secret)
            self.assertNotIn("subPath", mount, key)
            self.assertNotIn("subPathExpr", mount, key)
            self.assertIs(mount.get("readOnly"), True, key)
            self.assertIn(os.path.basename(self.config[key]), SECRET_KEYS[secret], key)
            source = next(v["secret"] for v in self.volumes.values()
                          if v.get("secret", {}).get("secretName") == secret)
            # items would rename or drop keys: the file names are the Secret's keys.
            self.assertNotIn("items", source, secret)
            self.assertIn(source.get("optional", False), (False,), secret)
            mode = source.get("defaultMode", 0o644)
            self.assertEqual(mode & 0o007, 0, f"{secret}: readable by every user in the pod")
            self.assertEqual(mode & 0o040, 0o040, f"{secret}: the fsGroup must read it")
        self.assertEqual(used, set(SECRET_KEYS))
        for mount in self.container["volumeMounts"]:
            if "secret" in self.volumes[mount["name"]]:
                self.assertNotIn("subPath", mount, mount["name"])

    def test_certificate_example_fills_the_tls_secret(self):
        """deploy/certificate.yaml (cert-manager, outside the kustomization: the offline schema
        check does not know its kind) writes the Secret the pods mount, for the Services'
        names."""
        kustomization = yaml.safe_load((DEPLOY_DIR / "kustomization.yaml").read_text())
        self.assertNotIn("certificate.yaml", kustomization["resources"])
        certificate = yaml.safe_load((DEPLOY_DIR / "certificate.yaml").read_text())
        self.assertEqual((certificate["apiVersion"], certificate["kind"]),
                         ("cert-manager.io/v1", "Certificate"))
        spec = certificate["spec"]
        _, secret = self.secret_mount(self.config["SOILVOL_TLS_CERT"])
        self.assertEqual(spec["secretName"], secret)
        self.assertIn("server auth", spec["usages"])
        self.assertTrue(spec["issuerRef"]["name"])
        for service in [r for r in self.resources if r["kind"] == "Service"]:
            name = service["metadata"]["name"]
            self.assertIn(name, spec["dnsNames"])
            self.assertTrue(any(re.fullmatch(rf"{re.escape(name)}\.[a-z0-9-]+\.svc\.cluster\.local",
                                             n) for n in spec["dnsNames"]), name)

    def test_data_volume_is_mounted_at_data_dir(self):
        claim = only(self.resources, "PersistentVolumeClaim")["metadata"]["name"]
        volumes = {v["name"]: v for v in self.pod["spec"]["volumes"]}
        mounts = {m["mountPath"]: m["name"] for m in self.container["volumeMounts"]}
        self.assertIn(self.config["SOILVOL_DATA_DIR"], mounts)
        self.assertIn("/tmp", mounts)
        data = volumes[mounts[self.config["SOILVOL_DATA_DIR"]]]
        self.assertEqual(data["persistentVolumeClaim"]["claimName"], claim)
        # The root filesystem is read-only: /tmp must be a volume.
        self.assertIn("emptyDir", volumes[mounts["/tmp"]])

    def test_pod_runs_as_the_image_user_without_privileges(self):
        pod = self.pod["spec"]["securityContext"]
        self.assertEqual((pod["runAsUser"], pod["runAsGroup"], pod["fsGroup"]), (IMAGE_UID,) * 3)
        self.assertIs(pod["runAsNonRoot"], True)
        self.assertEqual(pod["seccompProfile"]["type"], "RuntimeDefault")
        container = self.container["securityContext"]
        self.assertIs(container["readOnlyRootFilesystem"], True)
        self.assertIs(container["allowPrivilegeEscalation"], False)
        self.assertEqual(container["capabilities"]["drop"], ["ALL"])

    @unittest.skipUnless(DOCKERFILE.exists(), "docker/Dockerfile not written yet")
    def test_dockerfile_user_ports_and_data_dir_match(self):
        stage = dockerfile_server_stage()
        users = [arg for keyword, arg in stage if keyword == "USER"]
        self.assertTrue(users, "no USER in the server stage of the Dockerfile")
        # Numeric, so that runAsNonRoot can check it even without runAsUser.
        user, _, group = users[-1].partition(":")
        self.assertEqual(user, str(IMAGE_UID))
        self.assertIn(group, ("", str(IMAGE_UID)))
        exposed = {int(p.split("/")[0]) for keyword, arg in stage if keyword == "EXPOSE"
                   for p in arg.split()}
        self.assertEqual(exposed, {self.grpc_port, self.http_port, self.probe_port})
        env = dict(re.findall(r"(SOILVOL_\w+)=(\S+)", " ".join(
            arg for keyword, arg in stage if keyword == "ENV")))
        # The image and the pods read the same files at the same places.
        for key in ("SOILVOL_DATA_DIR",) + SECRET_FILES:
            if key in env:
                self.assertEqual(env[key], self.config[key], key)

    def test_shutdown_fits_in_the_grace_period(self):
        grace = float(self.config["SOILVOL_SHUTDOWN_GRACE_S"])
        delay = prestop_seconds(self.container)
        self.assertGreater(self.pod["spec"]["terminationGracePeriodSeconds"], grace + delay)

    def test_threads_fit_the_cpu_limit(self):
        resources = self.container["resources"]
        limit = cpu_cores(resources["limits"]["cpu"])
        self.assertLessEqual(cpu_cores(resources["requests"]["cpu"]), limit)
        workers = int(self.config["SOILVOL_WORKERS"])
        # The server gives each call cpus / workers engine threads (at least 1): more workers
        # than CPUs would run more threads than the limit allows.
        self.assertGreaterEqual(workers, 1)
        self.assertLessEqual(workers, limit)
        env = {e["name"] for e in self.container.get("env", [])}
        # omp_set_num_threads and cv::setNumThreads in the server win over these anyway.
        self.assertFalse(env & {"OMP_NUM_THREADS", "OPENCV_FOR_THREADS_NUM"},
                         "the server sizes its thread pools itself")

    def test_volume_is_read_write_many(self):
        pvc = only(self.resources, "PersistentVolumeClaim")
        self.assertEqual(pvc["spec"]["accessModes"], ["ReadWriteMany"])

    def test_autoscaler_owns_the_deployment(self):
        hpa = only(self.resources, "HorizontalPodAutoscaler")["spec"]
        target = hpa["scaleTargetRef"]
        self.assertEqual((target["apiVersion"], target["kind"], target["name"]),
                         ("apps/v1", "Deployment", self.deployment["metadata"]["name"]))
        self.assertGreaterEqual(hpa["minReplicas"], 2)
        self.assertGreaterEqual(hpa["maxReplicas"], hpa["minReplicas"])
        # A replicas field would undo the autoscaler at every `kubectl apply`.
        self.assertNotIn("replicas", list(self.deployment["spec"]))

    def test_disruption_budget_leaves_pods_running(self):
        budget = only(self.resources, "PodDisruptionBudget")["spec"]
        self.assertTrue(budget.get("maxUnavailable") == 1 or budget.get("minAvailable", 0) >= 1,
                        f"PodDisruptionBudget: {budget}")

    def test_selectors_match_pod_labels(self):
        self.assertSelects(self.deployment["spec"]["selector"]["matchLabels"], "Deployment")
        pdb = only(self.resources, "PodDisruptionBudget")["spec"]["selector"]
        self.assertNotIn("matchExpressions", pdb)
        self.assertSelects(pdb["matchLabels"], "PodDisruptionBudget")
        for service in [r for r in self.resources if r["kind"] == "Service"]:
            self.assertSelects(service["spec"]["selector"], service["metadata"]["name"])
        for spread in self.pod["spec"].get("topologySpreadConstraints", []):
            self.assertSelects(spread["labelSelector"]["matchLabels"], spread["topologyKey"])

    @unittest.skipUnless(shutil.which("openssl"), "needs the openssl CLI")
    def test_server_accepts_the_configuration(self):
        """The ConfigMap and container env, with dev-secrets.sh's files where the Secrets are
        mounted, start the server; the probes' paths answer on the probe port; TLS and the
        token are asked for; SIGTERM stops it with exit 0."""
        # The pod's environment (ServerProcess drops our own SOILVOL_* variables).
        env = dict(self.config)
        env.update({e["name"]: e["value"] for e in self.container.get("env", []) if "value" in e})
        secrets = DevSecrets()
        mounts = {}
        for key in SECRET_FILES:
            if self.config[key]:
                mount, secret = self.secret_mount(self.config[key])
                folder = secrets.tls if secret == "soilvol-tls" else secrets.auth
                mounts[mount["mountPath"]] = folder
        server = ServerProcess(SERVER_BIN, secrets.mounted(env, mounts))
        try:
            started = server.wait_listening()
            self.assertEqual(started["workers"], int(self.config["SOILVOL_WORKERS"]))
            self.assertEqual((started["tls"], started["auth"]), ("on", "tokens"))
            self.check_endpoints(started, secrets)
        finally:
            code = server.stop(float(self.config["SOILVOL_SHUTDOWN_GRACE_S"]) + 20)
            secrets.close()
        self.assertEqual(code, 0, "soilvol-server exit code after SIGTERM")

    def check_endpoints(self, started, secrets):
        probe = f"http://127.0.0.1:{started['probe_port']}"
        for name in ("startupProbe", "livenessProbe", "readinessProbe"):
            path = self.container[name]["httpGet"]["path"]
            self.assertEqual(rest(probe + path), 200, f"{name} {path}")
        scrape = self.pod["metadata"]["annotations"]["prometheus.io/path"]
        self.assertEqual(rest(probe + scrape), 200, "Prometheus' scrape")
        https = f"https://127.0.0.1:{started['http_port']}"
        self.assertEqual(rest(https + "/metrics", secrets.ca), 401, "metrics auth on REST")
        self.assertEqual(rest(https + "/metrics", secrets.ca, secrets.token), 200)
        self.assertEqual(rest(https + "/v1/containers", secrets.ca), 401)
        self.assertEqual(rest(https + "/v1/containers", secrets.ca, secrets.token), 200)
        if importlib.util.find_spec("grpc") is None:  # python3-grpcio
            print("note: python3-grpcio missing, gRPC over TLS not tried", file=sys.stderr)
            return
        port = started["grpc_port"]
        self.assertEqual(grpc_code(port, "/grpc.health.v1.Health/Check", secrets.ca), "SERVING")
        method = "/soilvol.v1.SoilVolume/ListContainers"
        self.assertEqual(grpc_code(port, method, secrets.ca), "UNAUTHENTICATED")
        self.assertEqual(grpc_code(port, method, secrets.ca, secrets.token), "OK")
        reflection = "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo"
        if self.config["SOILVOL_REFLECTION"] == "false":
            # A streaming method called as unary: UNIMPLEMENTED when it is not registered.
            self.assertEqual(grpc_code(port, reflection, secrets.ca), "UNIMPLEMENTED")


if __name__ == "__main__":
    unittest.main(verbosity=2)
