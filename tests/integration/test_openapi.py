"""The OpenAPI document the server serves at /openapi.json (generated from the proto by
protoc-gen-swagger at build time) against the live REST routes and the service descriptor:
every documented path and verb is routed, and every annotated RPC is documented."""
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(__file__))
from harness import load_grpc, shared_server  # noqa: E402

grpc, pb, pb_grpc = load_grpc()
from google.api import annotations_pb2  # noqa: E402  (generated beside the stubs)

VERBS = ("get", "post", "put", "patch", "delete")


def annotated_routes():
    """{(verb, path): rpc name} from the google.api.http annotations of soilvol.v1.SoilVolume."""
    routes = {}
    for method in pb.DESCRIPTOR.services_by_name["SoilVolume"].methods:
        options = method.GetOptions()
        if not options.HasExtension(annotations_pb2.http):
            continue
        rule = options.Extensions[annotations_pb2.http]
        verb = rule.WhichOneof("pattern")
        routes[(verb, getattr(rule, verb))] = method.name
    return routes


class OpenApi(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = shared_server()
        status, cls.doc = cls.server.rest("GET", "/openapi.json", headers={"Authorization": None})
        assert status == 200, (status, cls.doc)

    @classmethod
    def tearDownClass(cls):
        cls.server.close()

    def documented(self):
        return {(verb, path): op["operationId"] for path, item in self.doc["paths"].items()
                for verb, op in item.items() if verb in VERBS}

    def test_document_describes_this_server(self):
        self.assertEqual(self.doc["swagger"], "2.0")
        status, info = self.server.rest("GET", "/v1/info")
        self.assertEqual(status, 200, info)
        self.assertEqual(self.doc["info"]["version"], info["version"])
        self.assertIn("rpcStatus", self.doc["definitions"])
        estimate = self.doc["paths"]["/v1/containers/{container_id}:estimate"]["post"]
        self.assertIn("application/octet-stream", estimate["consumes"])
        self.assertIn("multipart/form-data", estimate["consumes"])
        register = self.doc["paths"]["/v1/containers"]["post"]
        self.assertIn("multipart/form-data", register["consumes"])
        # A registration's mesh travels as bytes (base64 in JSON) beside its placement.
        mesh = self.doc["definitions"]["v1MeshScan"]["properties"]
        self.assertEqual(mesh["data"]["format"], "byte")
        self.assertEqual(set(mesh), {"data", "corners", "container_pose", "range_noise_m"})
        self.assertIn("warnings", self.doc["definitions"]["v1Container"]["properties"])

    def test_every_annotated_rpc_is_documented(self):
        self.assertEqual(self.documented(), annotated_routes())

    def test_every_documented_route_is_served(self):
        for (verb, path), operation in self.documented().items():
            with self.subTest(operation):
                concrete = path.replace("{container_id}", "openapi-probe").replace(
                    "{calibration_id}", "openapi-probe")
                if concrete.endswith(":watch"):  # a stream: a bad id answers at once
                    concrete += "?afterEstimateId=probe"
                body = {} if verb in ("post", "put", "patch") else None
                status, answer = self.server.rest(verb.upper(), concrete, body)
                self.assertNotEqual(status, 405, (verb, concrete, answer))
                unrouted = status == 404 and "no route" in str(answer)
                self.assertFalse(unrouted, (verb, concrete, answer))
        # An undocumented path is not routed: the check above can fail.
        status, answer = self.server.rest("GET", "/v1/undocumented")
        self.assertEqual(status, 404)
        self.assertIn("no route", answer["message"])


if __name__ == "__main__":
    unittest.main(verbosity=2)
