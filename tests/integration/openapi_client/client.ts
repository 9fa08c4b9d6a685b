// A REST client generated from the server's /openapi.json (openapi-typescript types, openapi-fetch
// calls), compiled with tsc --strict and run by test_openapi_tools.py against a live server: the
// names used below must exist in the document for it to compile, and the answers must carry them.
// Environment: SOILVOL_URL, SOILVOL_TOKEN (optional), SOILVOL_EMPTY and SOILVOL_SCAN (PLY files),
// SOILVOL_CORNERS (JSON [{x, y, z}] x4), SOILVOL_CONTAINER_ID. Prints one key=value a line.
import {readFileSync} from "node:fs";
import createClient from "openapi-fetch";
import type {components, paths} from "./schema.js";

type Status = components["schemas"]["rpcStatus"];

function env(name: string): string {
    const value = process.env[name];
    if (value === undefined) throw new Error(`${name} is not set`);
    return value;
}

function expect(condition: unknown, what: string): asserts condition {
    if (!condition) throw new Error(what);
}

function report(pairs: Record<string, unknown>): void {
    for (const [key, value] of Object.entries(pairs)) console.log(`${key}=${value}`);
}

function fail(what: string, error: Status | undefined, status: number): never {
    throw new Error(`${what}: HTTP ${status} ${JSON.stringify(error)}`);
}

const token = process.env.SOILVOL_TOKEN;
const client = createClient<paths>({
    baseUrl: env("SOILVOL_URL"),
    headers: token ? {Authorization: `Bearer ${token}`} : {},
});
const id = env("SOILVOL_CONTAINER_ID");
const path = {container_id: id};
const corners: components["schemas"]["v1Point3"][] = JSON.parse(env("SOILVOL_CORNERS"));
const base64 = (file: string) => readFileSync(file).toString("base64");

const registered = await client.POST("/v1/containers", {
    body: {containerId: id, overwrite: true, scan: {cloud: {data: base64(env("SOILVOL_EMPTY"))}},
           opening: {corners}},
});
if (!registered.data) fail("register", registered.error, registered.response.status);
const container: components["schemas"]["v1Container"] = registered.data;
report({registered: container.containerId, struckCapacityM3: container.struckCapacityM3});

const estimated = await client.POST("/v1/containers/{container_id}:estimate", {
    params: {path, header: {"X-Request-Id": "generated-client-1"}},
    body: {scan: {cloud: {data: base64(env("SOILVOL_SCAN"))}}, omitHeightmap: true},
});
if (!estimated.data) fail("estimate", estimated.error, estimated.response.status);
const estimate = estimated.data;
expect(estimate.estimateId, "the estimate names no record");
report({volumeM3: estimate.volumeM3, fillRatio: estimate.fillRatio,
        estimateId: estimate.estimateId, cellsWithSoil: estimate.cells?.withSoil});

const got = await client.GET("/v1/containers/{container_id}", {params: {path}});
if (!got.data) fail("get", got.error, got.response.status);
report({etag: got.data.etag});

const listed = await client.GET("/v1/containers", {params: {query: {pageSize: 1000}}});
if (!listed.data) fail("list", listed.error, listed.response.status);
const ids = (listed.data.containers ?? []).map((c) => c.containerId);
report({listed: ids.includes(id)});

const patched = await client.PATCH("/v1/containers/{container_id}", {
    params: {path},
    body: {displayName: "From the generated client", loadTargets: {volumeM3: 0.05}},
});
if (!patched.data) fail("patch", patched.error, patched.response.status);
report({displayName: patched.data.displayName, targetVolumeM3: patched.data.loadTargets?.volumeM3});

const record = await client.GET("/v1/containers/{container_id}/estimates/{estimate_id}", {
    params: {path: {container_id: id, estimate_id: estimate.estimateId}},
});
if (!record.data) fail("record", record.error, record.response.status);
report({recordVolumeM3: record.data.result?.volumeM3});

const deleted = await client.DELETE("/v1/containers/{container_id}", {params: {path}});
if (!deleted.data) fail("delete", deleted.error, deleted.response.status);

// An error is a google.rpc.Status, typed by the document's `default` response.
const missing = await client.GET("/v1/containers/{container_id}", {params: {path}});
expect(!missing.data && missing.error, "a deleted container was found");
const status: Status = missing.error;
const reason = status.details?.find((d) => d["@type"].endsWith("google.rpc.ErrorInfo"));
report({errorHttp: missing.response.status, errorCode: status.code, errorReason: reason?.["reason"]});
