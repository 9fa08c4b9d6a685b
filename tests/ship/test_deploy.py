#!/usr/bin/env python3
"""deploy/ agrees with the server: its flags, ports, health services, data dir, user, shutdown.

Reads the resources listed in deploy/kustomization.yaml (selectors and pod labels are written out
there, so no rendering is needed) and runs the server binary with the ConfigMap as its
environment. SOILVOL_SERVER_BIN: the server (default /tmp/build/server/soilvol-server);
SOILVOL_DEPLOY_DIR: the manifests (default deploy/ of this checkout). Exit 77 = skipped
(no python3-yaml).
"""
import importlib.util
import os
import re
import sys
import unittest
import urllib.request
from pathlib import Path

try:
    import yaml
except ImportError:
    print("skipped: python3-yaml is not installed (apt-get install python3-yaml)")
    sys.exit(77)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ship_common import ServerProcess, help_env, parse_dockerfile, port_of  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DEPLOY_DIR = Path(os.environ.get("SOILVOL_DEPLOY_DIR", ROOT / "deploy"))
DOCKERFILE = ROOT / "docker" / "Dockerfile"
SERVER_BIN = os.environ.get("SOILVOL_SERVER_BIN", "/tmp/build/server/soilvol-server")

IMAGE_UID = 10001  # the image's user soilvol (docker/README.md, the Dockerfile contract)
HEALTH_SERVICES = {"", "soilvol.v1.SoilVolume", "liveness"}  # server/health_service.cpp


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


def health_check(port, service):
    """grpc.health.v1.Health/Check by hand-encoded protobuf: returns the status number."""
    import grpc
    # HealthCheckRequest{service = 1}: 0x0a, one length byte (the names are short), the name.
    request = b"\x0a" + bytes([len(service)]) + service.encode() if service else b""
    no_proxy = [("grpc.enable_http_proxy", 0)]
    with grpc.insecure_channel(f"127.0.0.1:{port}", options=no_proxy) as channel:
        check = channel.unary_unary("/grpc.health.v1.Health/Check")
        response = check(request, timeout=10)
    # HealthCheckResponse{status = 1}: 0x08 then the enum; absent = UNKNOWN (0).
    return response[1] if response[:1] == b"\x08" else 0


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
        self.assertEqual(ports, {"grpc": self.grpc_port, "http": self.http_port})
        for probe in ("startupProbe", "livenessProbe", "readinessProbe"):
            self.assertEqual(self.container[probe]["grpc"]["port"], self.grpc_port, probe)
        annotations = self.pod["metadata"]["annotations"]
        self.assertEqual(annotations["prometheus.io/port"], str(self.http_port))
        self.assertEqual(annotations["prometheus.io/path"], "/metrics")
        for service in [r for r in self.resources if r["kind"] == "Service"]:
            for port in service["spec"]["ports"]:
                target = port.get("targetPort", port["port"])
                target = ports.get(target, target)  # a name resolves to the container port
                self.assertEqual(target, ports[port["name"]],
                                 f"Service {service['metadata']['name']} port {port['name']}")
                if port["name"] == "grpc":
                    self.assertEqual(port.get("appProtocol"), "kubernetes.io/h2c")

    def test_probes_ask_health_services_the_server_answers(self):
        self.assertEqual(self.container["livenessProbe"]["grpc"]["service"], "liveness")
        self.assertIn(self.container["readinessProbe"]["grpc"].get("service", ""),
                      {"", "soilvol.v1.SoilVolume"})
        self.assertIn(self.container["startupProbe"]["grpc"].get("service", ""), HEALTH_SERVICES)

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
        self.assertEqual(exposed, {self.grpc_port, self.http_port})
        env = dict(re.findall(r"(SOILVOL_\w+)=(\S+)", " ".join(
            arg for keyword, arg in stage if keyword == "ENV")))
        self.assertEqual(env.get("SOILVOL_DATA_DIR"), self.config["SOILVOL_DATA_DIR"])

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

    def test_server_accepts_the_configuration(self):
        """The ConfigMap and container env start the server; it serves the probes; SIGTERM
        stops it with exit 0."""
        # The pod's environment (ServerProcess drops our own SOILVOL_* variables).
        env = dict(self.config)
        env.update({e["name"]: e["value"] for e in self.container.get("env", []) if "value" in e})
        server = ServerProcess(SERVER_BIN, env)
        try:
            started = server.wait_listening()
            self.assertEqual(started["workers"], int(self.config["SOILVOL_WORKERS"]))
            self.check_endpoints(started)
        finally:
            code = server.stop(float(self.config["SOILVOL_SHUTDOWN_GRACE_S"]) + 20)
        self.assertEqual(code, 0, "soilvol-server exit code after SIGTERM")

    def check_endpoints(self, started):
        base = f"http://127.0.0.1:{started['http_port']}"
        path = self.pod["metadata"]["annotations"]["prometheus.io/path"]
        direct = urllib.request.build_opener(urllib.request.ProxyHandler({}))
        for endpoint in ("/healthz", "/readyz", path):
            with direct.open(base + endpoint, timeout=10) as response:
                self.assertEqual(response.status, 200, endpoint)
        if importlib.util.find_spec("grpc") is None:  # python3-grpcio
            print("note: python3-grpcio missing, probe services not asked over gRPC",
                  file=sys.stderr)
            return
        for probe in ("startupProbe", "livenessProbe", "readinessProbe"):
            service = self.container[probe]["grpc"].get("service", "")
            self.assertEqual(health_check(started["grpc_port"], service), 1,
                             f"{probe} service '{service}' is not SERVING")


if __name__ == "__main__":
    unittest.main(verbosity=2)
