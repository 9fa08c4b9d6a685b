"""The OpenAPI 3.0 document the server serves at /openapi.json (proto/openapi/, made by
scripts/gen-openapi.sh) against the live server and the service descriptor: every documented path
and verb is routed, every annotated RPC is documented, the routes documented as open answer
without a token, the JSON names of the schemas are those of real responses (register, get,
list, estimate, records), and errors are the documented google.rpc.Status."""
import os
import re
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(__file__))
import box_scene  # noqa: E402
from harness import (Server, cloud_scan, corners_json, load_grpc, needs_own_server,  # noqa: E402
                     shared_server, token_line)

grpc, pb, pb_grpc = load_grpc()
from google.api import annotations_pb2  # noqa: E402  (generated beside the stubs)

VERBS = ("get", "post", "put", "patch", "delete")
PROBE = "openapi-probe"


def annotated_routes():
    """{(verb, path): rpc name} from the google.api.http annotations of soilvol.v1.SoilVolume,
    nested path fields ({container.container_id}) by their last name, as the document has them."""
    routes = {}
    for method in pb.DESCRIPTOR.services_by_name["SoilVolume"].methods:
        options = method.GetOptions()
        if not options.HasExtension(annotations_pb2.http):
            continue
        rule = options.Extensions[annotations_pb2.http]
        verb = rule.WhichOneof("pattern")
        path = re.sub(r"\{(?:\w+\.)+(\w+)\}", r"{\1}", getattr(rule, verb))
        routes[(verb, path)] = method.name
    return routes


class Schemas:
    """Resolves $refs of the document's components."""

    def __init__(self, doc):
        self.doc = doc

    def resolve(self, schema):
        while "$ref" in schema:
            node = self.doc
            for part in schema["$ref"].lstrip("#/").split("/"):
                node = node[part]
            schema = node
        return schema

    def undocumented(self, value, schema, at="$"):
        """The JSON paths of `value` that `schema` does not name (wrong name or wrong type)."""
        schema = self.resolve(schema)
        kind = schema.get("type", "object" if "properties" in schema else None)
        if isinstance(value, dict):
            if kind != "object":
                return [f"{at}: an object where the schema says {kind}"]
            properties = schema.get("properties", {})
            extra = schema.get("additionalProperties")
            out = []
            for key, item in value.items():
                if key in properties:
                    out += self.undocumented(item, properties[key], f"{at}.{key}")
                elif isinstance(extra, dict):
                    out += self.undocumented(item, extra, f"{at}.{key}")
                elif extra is not True:
                    out.append(f"{at}.{key}: not in {sorted(properties)}")
            return out
        if isinstance(value, list):
            if kind != "array":
                return [f"{at}: an array where the schema says {kind}"]
            return [p for i, item in enumerate(value)
                    for p in self.undocumented(item, schema["items"], f"{at}[{i}]")]
        expected = {str: ("string",), bool: ("boolean",), int: ("integer", "number"),
                    float: ("number",)}[type(value)]
        if kind is not None and kind not in expected:
            return [f"{at}: {type(value).__name__} where the schema says {kind}"]
        if kind == "string" and "enum" in schema and value not in schema["enum"]:
            return [f"{at}: {value!r} not in the enum"]
        return []


class OpenApi(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = shared_server()
        status, cls.doc = cls.server.rest("GET", "/openapi.json", headers={"Authorization": None})
        assert status == 200, (status, cls.doc)
        cls.schemas = Schemas(cls.doc)

    @classmethod
    def tearDownClass(cls):
        cls.server.close()

    def operations(self):
        return {(verb, path): op for path, item in self.doc["paths"].items()
                for verb, op in item.items() if verb in VERBS}

    def response_schema(self, operation_id, status="200"):
        for op in self.operations().values():
            if op["operationId"] == operation_id:
                return op["responses"][status]["content"]["application/json"]["schema"]
        raise KeyError(operation_id)

    def assertDocumented(self, operation_id, value, status="200"):
        problems = self.schemas.undocumented(value, self.response_schema(operation_id, status))
        self.assertEqual(problems, [], operation_id)

    def test_document_describes_this_server(self):
        self.assertRegex(self.doc["openapi"], r"^3\.0\.\d+$")
        status, info = self.server.rest("GET", "/v1/info")
        self.assertEqual(status, 200, info)
        self.assertEqual(self.doc["info"]["version"], info["version"])
        scheme = self.doc["components"]["securitySchemes"]["bearerAuth"]
        self.assertEqual((scheme["type"], scheme["scheme"]), ("http", "bearer"))
        self.assertEqual(self.doc["security"], [{"bearerAuth": []}])
        ops = self.operations()
        for route in ("/v1/containers", "/v1/containers/{container_id}:estimate"):
            content = ops[("post", route)]["requestBody"]["content"]
            self.assertEqual(set(content), {"application/json", "application/octet-stream",
                                            "multipart/form-data"})
            parts = content["multipart/form-data"]["schema"]["properties"]
            self.assertTrue({"request", "cloud", "left", "right"} <= set(parts), parts)
        self.assertIn("mesh", ops[("post", "/v1/containers")]["requestBody"]["content"][
            "multipart/form-data"]["schema"]["properties"])
        watch = ops[("get", "/v1/estimates:watch")]["responses"]["200"]["content"]
        self.assertEqual(set(watch), {"text/event-stream"})
        png = ops[("get", "/v1/containers/{container_id}/estimates/{estimate_id}/heightmap.png")]
        self.assertIn("image/png", png["responses"]["200"]["content"])
        for route in ("/healthz", "/readyz", "/metrics", "/openapi.json", "/"):
            self.assertIn(("get", route), ops)
        # A registration's mesh travels as bytes (base64 in JSON) beside its placement.
        mesh = self.doc["components"]["schemas"]["v1MeshScan"]["properties"]
        self.assertEqual(mesh["data"]["format"], "byte")
        self.assertEqual(set(mesh), {"data", "corners", "containerPose", "rangeNoiseM"})

    def test_every_operation_documents_status_errors(self):
        for (verb, path), op in self.operations().items():
            if op.get("security") == [] and "default" not in op["responses"]:
                continue  # probes, the document, the dashboard's page: no error body of their own
            with self.subTest(op["operationId"]):
                error = self.schemas.resolve(op["responses"]["default"])
                schema = self.schemas.resolve(error["content"]["application/json"]["schema"])
                self.assertEqual(set(schema["properties"]), {"code", "message", "details"})
                any_ = self.schemas.resolve(schema["properties"]["details"]["items"])
                self.assertEqual(any_["required"], ["@type"])

    def test_every_annotated_rpc_is_documented(self):
        documented = {key: op["operationId"] for key, op in self.operations().items()
                      if op["operationId"] in set(annotated_routes().values())}
        self.assertEqual(documented, annotated_routes())

    def test_every_documented_route_is_served(self):
        for (verb, path), op in self.operations().items():
            with self.subTest(op["operationId"]):
                concrete = re.sub(r"\{\w+\}", PROBE, path)
                if concrete.endswith(":watch"):  # a stream: a bad id answers at once
                    concrete += "?afterEstimateId=probe"
                body = {} if verb in ("post", "put", "patch") else None
                # Routes documented as open must answer without a token.
                headers = {"Authorization": None} if op.get("security") == [] else None
                status, answer = self.server.rest(verb.upper(), concrete, body, headers=headers)
                self.assertNotIn(status, (401, 403, 405), (verb, concrete, answer))
                unrouted = status == 404 and "no route" in str(answer)
                self.assertFalse(unrouted, (verb, concrete, answer))
        # An undocumented path is not routed: the check above can fail.
        status, answer = self.server.rest("GET", "/v1/undocumented")
        self.assertEqual(status, 404)
        self.assertIn("no route", answer["message"])

    def test_json_names_are_those_the_server_sends(self):
        empty = box_scene.encode_ply(box_scene.box_scan(0.0, seed=1))
        status, container = self.server.rest("POST", "/v1/containers", {
            "containerId": "openapi-names", "scan": cloud_scan(empty), "overwrite": True,
            "opening": corners_json(box_scene.opening_corners()),
            "material": {"name": "clay", "looseDensityKgM3": 1600},
            "loadTargets": {"volumeM3": 0.05}})
        self.assertEqual(status, 200, container)
        self.assertIn("struckCapacityM3", container)
        self.assertDocumented("RegisterContainer", container)
        scan = box_scene.encode_ply(box_scene.box_scan(0.3, seed=2))
        status, estimate = self.server.rest("POST", "/v1/containers/openapi-names:estimate",
                                            {"scan": cloud_scan(scan)})
        self.assertEqual(status, 200, estimate)
        self.assertIn("fillRatio", estimate)
        self.assertDocumented("EstimateVolume", estimate)
        calls = [("GetContainer", "/v1/containers/openapi-names"),
                 ("ListContainers", "/v1/containers"),
                 ("ListEstimates", "/v1/containers/openapi-names/estimates?view=ESTIMATE_VIEW_FULL"),
                 ("GetServerInfo", "/v1/info"),
                 ("ListCalibrations", "/v1/calibrations")]
        if estimate.get("estimateId"):
            calls.append(("GetEstimate", "/v1/containers/openapi-names/estimates/"
                                         f"{estimate['estimateId']}"))
        for operation_id, path in calls:
            with self.subTest(operation_id):
                status, answer = self.server.rest("GET", path)
                self.assertEqual(status, 200, answer)
                self.assertDocumented(operation_id, answer)
        status, deleted = self.server.rest("DELETE", "/v1/containers/openapi-names")
        self.assertEqual(status, 200, deleted)
        self.assertDocumented("DeleteContainer", deleted)

    def test_errors_are_the_documented_status(self):
        cases = [("GET", "/v1/containers/openapi-missing", None, None, 404),
                 ("POST", "/v1/containers/openapi-missing:estimate", None,
                  {"Content-Type": "text/plain"}, 415),
                 ("PUT", "/v1/containers", None, None, 405),
                 ("POST", "/v1/containers", {"containerId": "bad id"}, None, 400)]
        for method, path, body, headers, expected in cases:
            with self.subTest(f"{method} {path}"):
                raw = b"x" if headers else None
                status, error = self.server.rest(method, path, body, raw=raw, headers=headers)
                self.assertEqual(status, expected, error)
                self.assertEqual(self.schemas.undocumented(
                    error, {"$ref": "#/components/schemas/rpcStatus"}), [])
                self.assertIsInstance(error["code"], int)
                self.assertTrue(error["message"])
                for detail in error.get("details", []):
                    self.assertIn("@type", detail)


@needs_own_server
class Security(unittest.TestCase):
    """The document's security against a server with a token file: the operations it documents
    as open answer without a token, every other one asks for it (401, WWW-Authenticate)."""

    TOKEN = "openapi-test-token-0123456789"

    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix="soilvol-openapi-auth-")
        tokens = os.path.join(cls.dir, "tokens")
        with open(tokens, "w") as f:
            f.write(token_line("openapi", "admin", cls.TOKEN))
        cls.server = Server(args=["--auth-tokens-file", tokens], token=cls.TOKEN).start()
        status, cls.doc = cls.server.rest("GET", "/openapi.json", headers={"Authorization": None})
        assert status == 200, (status, cls.doc)

    @classmethod
    def tearDownClass(cls):
        cls.server.close()

    def test_open_operations_are_open_and_the_others_ask_for_the_bearer_token(self):
        self.assertEqual(self.doc["security"], [{"bearerAuth": []}])
        for path, item in self.doc["paths"].items():
            for verb, op in item.items():
                security = op.get("security", self.doc["security"])
                concrete = re.sub(r"\{\w+\}", PROBE, path)
                body = {} if verb in ("post", "put", "patch") else None
                with self.subTest(op["operationId"]):
                    status, answer, headers = self.server.rest_with_headers(
                        verb.upper(), concrete, body, headers={"Authorization": None})
                    if security == [] or {} in security:  # open (/metrics: by default)
                        self.assertNotEqual(status, 401, (verb, concrete, answer))
                    else:
                        self.assertEqual(status, 401, (verb, concrete, answer))
                        self.assertIn("Bearer", headers.get("WWW-Authenticate", ""))


if __name__ == "__main__":
    unittest.main(verbosity=2)
