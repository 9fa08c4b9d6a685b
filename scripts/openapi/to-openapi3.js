// Turns protoc-gen-swagger's Swagger 2.0 document of soilvol.proto into the OpenAPI 3.0 document
// the server serves (scripts/gen-openapi.sh runs it): swagger2openapi converts, then what the proto
// cannot say is added: the routes of proto/openapi/routes.json, the bearer scheme, a google.rpc.Status
// `default` response on every operation, binary and multipart uploads, Server-Sent Events.
//   node to-openapi3.js <swagger.json> <routes.json> <version>   (the document on stdout)
"use strict";
const fs = require("fs");
const path = require("path");

const tools = process.env.SOILVOL_TOOLS_DIR ||
    path.join(require("os").homedir(), ".cache", "soilvol-tools");
const converter = require(path.join(tools, "node_modules", "swagger2openapi"));

const VERBS = ["get", "put", "post", "delete", "options", "head", "patch"];
// Files a body "*" route takes as application/octet-stream or multipart parts (server/README.md,
// Binary uploads; server/http_routes.cpp kFiles), by operation.
const UPLOADS = {
    RegisterContainer: ["cloud", "left", "right", "depth", "confidence", "mesh"],
    EstimateVolume: ["cloud", "left", "right", "depth", "confidence"],
};
// Server-streaming RPCs served as Server-Sent Events: their event name, id field and resume field.
const WATCHES = {
    WatchEstimates: {event: "estimate", id: "estimateId", resume: "afterEstimateId",
                     schema: "v1Estimate"},
    WatchAlerts: {event: "alert", id: "alertId", resume: "afterAlertId", schema: "v1Alert"},
    WatchLoads: {event: "load", id: "eventId", resume: "afterEventId", schema: "v1LoadEvent"},
};

function camel(name) {
    return name.replace(/_([a-z0-9])/g, (_, c) => c.toUpperCase());
}

function operations(doc) {
    const out = [];
    for (const [route, item] of Object.entries(doc.paths)) {
        for (const verb of VERBS) if (item[verb]) out.push({route, verb, op: item[verb]});
    }
    return out;
}

// grpc-gateway names a nested path field by its proto path ({container.container_id}); a
// generated client wants an identifier. The wire is the same.
function renamePathFields(doc) {
    const paths = {};
    for (const [route, item] of Object.entries(doc.paths)) {
        const renamed = route.replace(/\{([a-z0-9_]+\.)+([a-z0-9_]+)\}/g, "{$2}");
        for (const verb of VERBS) {
            for (const p of (item[verb] && item[verb].parameters) || []) {
                if (p.in === "path") p.name = p.name.replace(/^.*\./, "");
            }
        }
        paths[renamed] = Object.assign(paths[renamed] || {}, item);
    }
    doc.paths = paths;
}

// Query parameters as the README writes them (camelCase); the server takes both spellings.
function camelQueries(doc) {
    for (const {op} of operations(doc)) {
        for (const p of op.parameters || []) if (p.in === "query") p.name = camel(p.name);
    }
}

function scalarProperties(doc, schema) {
    const target = schema.$ref ? doc.components.schemas[schema.$ref.split("/").pop()] : schema;
    const out = {};
    for (const [name, property] of Object.entries(target.properties || {})) {
        const resolved = property.$ref ? doc.components.schemas[property.$ref.split("/").pop()]
                                       : property;
        if (["string", "number", "integer", "boolean"].includes(resolved.type) &&
            resolved.format !== "byte") {
            out[name] = property;
        }
    }
    return out;
}

function addUploads(doc, op, route) {
    const files = UPLOADS[op.operationId];
    const json = op.requestBody.content["application/json"];
    const inPath = new Set((op.parameters || []).filter((p) => p.in === "path").map((p) => p.name));
    op.requestBody.content["application/octet-stream"] = {
        schema: {type: "string", format: "binary",
                 description: "One file: the cloud, or the file `file` names; every other field " +
                              "in the query."},
    };
    const parts = {
        request: {type: "string",
                  description: "The request as JSON (the application/json body); files beside it."},
    };
    for (const name of files) {
        parts[name] = {type: "string", format: "binary",
                       description: {cloud: "scan.cloud.data", left: "scan.stereo.left",
                                     right: "scan.stereo.right", depth: "scan.depth.depth",
                                     confidence: "scan.depth.confidence",
                                     mesh: "mesh.data"}[name]};
    }
    op.requestBody.content["multipart/form-data"] = {
        schema: {type: "object", properties: parts,
                 additionalProperties: {type: "string"},
                 description: "Part `request` (JSON) and file parts; any other part names a " +
                              "field as a query parameter would."},
        encoding: {request: {contentType: "application/json"}},
    };
    const only = "Binary and multipart bodies only (a JSON body carries every field; a query " +
                 "beside it is refused).";
    op.parameters = op.parameters || [];
    op.parameters.push({
        name: "file", in: "query", required: false,
        description: `Which file an application/octet-stream body is. ${only}`,
        schema: {type: "string",
                 enum: files.filter((f) => !["left", "right", "confidence"].includes(f)),
                 default: "cloud"},
    });
    for (const [name, property] of Object.entries(scalarProperties(doc, json.schema))) {
        if (inPath.has(name) || inPath.has(name.replace(/[A-Z]/g, (c) => "_" + c.toLowerCase()))) {
            continue;
        }
        op.parameters.push({name, in: "query", required: false, description: only,
                            schema: property});
    }
    op.description = (op.description ? op.description + "\n\n" : "") +
        "The scan (and a registration's mesh) may come as files: an application/octet-stream " +
        "body (the other fields as query parameters, dotted paths; a message field as its " +
        "proto3 JSON) or multipart/form-data (server/README.md, Binary uploads).";
}

function documentWatch(op, watch) {
    const ok = op.responses["200"];
    ok.description = `Server-Sent Events: \`retry: 1000\`, then per new message \`id: <${watch.id}>\`, ` +
        `\`event: ${watch.event}\`, \`data: <the message as JSON (${watch.schema})>\`; comment ` +
        "lines keep the connection alive; a failure ends the stream with `event: error`, " +
        "`data: <a google.rpc.Status as JSON>`.";
    ok.content = {"text/event-stream": {schema: {type: "string"}}};
    op.parameters = op.parameters || [];
    op.parameters.push({
        name: "Last-Event-ID", in: "header", required: false,
        description: `An EventSource's reconnect: resume after this id (as ${watch.resume}).`,
        schema: {type: "string"},
    });
}

function main() {
    const [swaggerPath, routesPath, version] = process.argv.slice(2);
    const swagger = JSON.parse(fs.readFileSync(swaggerPath, "utf8"));
    const routes = JSON.parse(fs.readFileSync(routesPath, "utf8"));
    converter.convertObj(swagger, {patch: true, warnOnly: false}, (err, result) => {
        if (err) throw err;
        const doc = result.openapi;
        doc.info = {
            title: "soilvol",
            version,
            description: "Volume of soil in a bucket, truck bed or bin, from a stereo pair or a " +
                "3D point cloud. The RPCs are generated from proto/soilvol/v1/soilvol.proto " +
                "(JSON names as the server sends them; int64 as strings, bytes as base64); " +
                "errors are google.rpc.Status. Regenerate with scripts/gen-openapi.sh.",
        };
        doc.servers = [{url: "/"}];
        renamePathFields(doc);
        camelQueries(doc);
        Object.assign(doc.components.schemas, routes.components.schemas);
        for (const key of ["securitySchemes", "responses", "parameters"]) {
            doc.components[key] = Object.assign(doc.components[key] || {}, routes.components[key]);
        }
        for (const {route, op} of operations(doc)) {
            op.responses.default = {$ref: "#/components/responses/Error"};
            op.parameters = (op.parameters || []).concat(
                [{$ref: "#/components/parameters/RequestId"},
                 {$ref: "#/components/parameters/GrpcTimeout"}]);
            if (UPLOADS[op.operationId]) addUploads(doc, op, route);
            if (WATCHES[op.operationId]) documentWatch(op, WATCHES[op.operationId]);
            if (op.operationId === "UpdateContainer") {  // protoc-gen-swagger 1.6 drops messages
                op.parameters.push({
                    name: "updateMask", in: "query", required: false,
                    description: "google.protobuf.FieldMask: the fields to change, comma-separated " +
                                 "(displayName,loadTargets.payloadKg); without it, the fields " +
                                 "the body carries.",
                    schema: {type: "string"},
                });
            }
        }
        for (const [route, item] of Object.entries(routes.paths)) {
            if (doc.paths[route]) throw new Error(`${route}: in the proto and in routes.json`);
            doc.paths[route] = item;
        }
        doc.security = [{bearerAuth: []}];
        process.stdout.write(JSON.stringify(doc, null, 2) + "\n");
    });
}

main();
