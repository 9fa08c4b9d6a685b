#!/usr/bin/env node
// Validates Kubernetes manifests offline against the API's OpenAPI schemas (npm
// kubernetes-models), and renders deploy/ without kubectl.
//
//   validate_k8s.js [FILE]                        validate multi-document YAML (stdin without FILE)
//   validate_k8s.js --kustomize DIR               render DIR/kustomization.yaml here, validate it
//   validate_k8s.js --kustomize DIR --print       print that rendering as YAML
//   validate_k8s.js --kustomize DIR --compare FILE   fail unless FILE (kubectl kustomize output)
//                                                 holds the same objects as our rendering
//
// Needs npm `yaml` and `kubernetes-models` on NODE_PATH. Exits 1 on any finding, 2 on bad usage
// or missing packages.
// The schemas have no additionalProperties: false, so a misspelt field is not caught here;
// tests/ship/test_deploy.py reads the fields that matter.
'use strict';

const fs = require('fs');
const path = require('path');

function loadPackage(name) {
    try {
        return require(name);
    } catch (error) {
        if (error.code !== 'MODULE_NOT_FOUND') throw error;
        console.error(`validate_k8s: npm package '${name}' not found; set NODE_PATH to a ` +
                      'node_modules holding yaml and kubernetes-models ' +
                      '(scripts/install-test-tools.sh installs them)');
        process.exit(2);
    }
}

const YAML = loadPackage('yaml');
loadPackage('kubernetes-models');

class Finding extends Error {}

// The API server reads YAML 1.1 (sigs.k8s.io/yaml), where `on` and `yes` are booleans.
function parseDocuments(text, source) {
    const objects = [];
    for (const doc of YAML.parseAllDocuments(text, { version: '1.1' })) {
        if (doc.errors.length > 0) throw new Finding(`${source}: ${doc.errors[0].message}`);
        const object = doc.toJS();
        if (object === null || object === undefined) continue;  // an empty document
        if (typeof object !== 'object' || Array.isArray(object)) {
            throw new Finding(`${source}: a document is not a mapping`);
        }
        objects.push({ object, source });
    }
    return objects;
}

function describe({ object, source }) {
    const name = object.metadata && object.metadata.name;
    return `${source}: ${object.kind || '(no kind)'}/${name || '(no name)'}`;
}

// kubernetes-models has one module per API group version: 'v1', 'apps/v1', 'autoscaling/v2'.
function modelClass(apiVersion, kind) {
    if (typeof apiVersion !== 'string' ||
        !/^([a-z0-9.-]+\/)?v[0-9]+((alpha|beta)[0-9]+)?$/.test(apiVersion)) {
        return null;
    }
    let group;
    try {
        group = require(`kubernetes-models/${apiVersion}`);
    } catch (error) {
        if (error.code === 'MODULE_NOT_FOUND' || error.code === 'ERR_PACKAGE_PATH_NOT_EXPORTED') {
            return null;
        }
        throw error;
    }
    const model = group[kind];
    // The group also exports nested types (DeploymentSpec); only resources carry apiVersion/kind.
    if (typeof model !== 'function' || model.apiVersion !== apiVersion || model.kind !== kind) {
        return null;
    }
    return model;
}

function validate(entries) {
    const seen = new Set();
    for (const entry of entries) {
        const { object } = entry;
        const label = describe(entry);
        const Model = modelClass(object.apiVersion, object.kind);
        if (Model === null) {
            throw new Finding(`${label}: unknown apiVersion/kind ` +
                              `${object.apiVersion}/${object.kind}`);
        }
        if (!object.metadata || typeof object.metadata.name !== 'string' || !object.metadata.name) {
            throw new Finding(`${label}: metadata.name is missing`);
        }
        const id = `${object.apiVersion}/${object.kind}/${object.metadata.namespace || ''}/` +
                   `${object.metadata.name}`;
        if (seen.has(id)) throw new Finding(`${label}: defined twice`);
        seen.add(id);
        try {
            new Model(object).validate();
        } catch (error) {
            throw new Finding(`${label}: ${error.message}`);
        }
    }
}

// --- A renderer for the subset of kustomize that deploy/ uses; anything else is refused. ---

const kSupportedFields = new Set(['apiVersion', 'kind', 'resources', 'labels', 'images']);
const kImageFields = new Set(['name', 'newName', 'newTag', 'digest']);

function readKustomization(dir) {
    const file = path.join(dir, 'kustomization.yaml');
    const docs = parseDocuments(fs.readFileSync(file, 'utf8'), file);
    if (docs.length !== 1) throw new Finding(`${file}: expected one document`);
    const k = docs[0].object;
    if (k.apiVersion !== 'kustomize.config.k8s.io/v1beta1' || k.kind !== 'Kustomization') {
        throw new Finding(`${file}: not a kustomize.config.k8s.io/v1beta1 Kustomization`);
    }
    for (const field of Object.keys(k)) {
        if (!kSupportedFields.has(field)) {
            throw new Finding(`${file}: field '${field}' is not supported by this renderer ` +
                              '(use kubectl kustomize, or extend tests/ship/validate_k8s.js)');
        }
    }
    return { file, k };
}

// Like kustomize's `labels` without includeSelectors/includeTemplates: metadata.labels only.
function applyLabels(objects, labels, file) {
    for (const entry of labels || []) {
        for (const option of ['includeSelectors', 'includeTemplates', 'fields']) {
            if (entry[option]) {
                throw new Finding(`${file}: labels.${option} is not supported by this renderer`);
            }
        }
        for (const object of objects) {
            object.metadata.labels = Object.assign(object.metadata.labels || {}, entry.pairs);
        }
    }
}

// 'registry:5000/app:1.0@sha256:...' -> name, tag, digest (kustomize's image.Split).
function splitImage(image) {
    let rest = image;
    let digest = '';
    const at = rest.indexOf('@');
    if (at >= 0) {
        digest = rest.slice(at + 1);
        rest = rest.slice(0, at);
    }
    let tag = '';
    const colon = rest.lastIndexOf(':');
    if (colon > rest.lastIndexOf('/')) {
        tag = rest.slice(colon + 1);
        rest = rest.slice(0, colon);
    }
    return { name: rest, tag, digest };
}

// kustomize's imageTagUpdater: a new tag or digest replaces both the old tag and digest.
function updateImage(image, rule) {
    let { name, tag, digest } = splitImage(image);
    if (rule.newName) name = rule.newName;
    if (rule.newTag !== undefined || rule.digest !== undefined) {
        tag = rule.newTag !== undefined ? String(rule.newTag) : '';
        digest = rule.digest !== undefined ? String(rule.digest) : '';
    }
    return name + (tag ? `:${tag}` : '') + (digest ? `@${digest}` : '');
}

function applyImages(value, rules) {
    if (Array.isArray(value)) {
        value.forEach((item) => applyImages(item, rules));
        return;
    }
    if (value === null || typeof value !== 'object') return;
    for (const [key, child] of Object.entries(value)) {
        if (['containers', 'initContainers', 'ephemeralContainers'].includes(key) &&
            Array.isArray(child)) {
            for (const container of child) {
                if (typeof container.image !== 'string') continue;
                const rule = rules.find((r) => splitImage(container.image).name === r.name);
                if (rule) container.image = updateImage(container.image, rule);
            }
        }
        applyImages(child, rules);
    }
}

function renderKustomization(dir) {
    const { file, k } = readKustomization(dir);
    const entries = [];
    for (const resource of k.resources || []) {
        const resourcePath = path.join(dir, resource);
        if (!fs.existsSync(resourcePath) || !fs.statSync(resourcePath).isFile()) {
            throw new Finding(`${file}: resource '${resource}' is not a file (this renderer ` +
                              'reads files only)');
        }
        entries.push(...parseDocuments(fs.readFileSync(resourcePath, 'utf8'), resourcePath));
    }
    for (const entry of entries) {
        if (!entry.object.metadata) throw new Finding(`${describe(entry)}: no metadata`);
    }
    const objects = entries.map((entry) => entry.object);
    applyLabels(objects, k.labels, file);
    for (const rule of k.images || []) {
        const unsupported = Object.keys(rule).filter((f) => !kImageFields.has(f));
        if (typeof rule.name !== 'string' || unsupported.length > 0) {
            throw new Finding(`${file}: an images entry needs a name and only ` +
                              `${[...kImageFields].join(', ')}`);
        }
    }
    applyImages(objects, k.images || []);
    return entries;
}

// --- Comparing two renderings as objects, ignoring order. ---

function keyOf(object) {
    const meta = object.metadata || {};
    return `${object.apiVersion}/${object.kind}/${meta.namespace || ''}/${meta.name}`;
}

function firstDifference(a, b, where) {
    if (typeof a !== typeof b || Array.isArray(a) !== Array.isArray(b) ||
        (a === null) !== (b === null)) {
        return `${where}: ${JSON.stringify(a)} != ${JSON.stringify(b)}`;
    }
    if (a === null || typeof a !== 'object') {
        return a === b ? null : `${where}: ${JSON.stringify(a)} != ${JSON.stringify(b)}`;
    }
    const keys = new Set([...Object.keys(a), ...Object.keys(b)]);
    for (const key of keys) {
        const difference = firstDifference(a[key], b[key], `${where}.${key}`);
        if (difference) return difference;
    }
    return null;
}

function compare(ours, theirs, theirSource) {
    const mine = new Map(ours.map((e) => [keyOf(e.object), e.object]));
    const other = new Map(theirs.map((e) => [keyOf(e.object), e.object]));
    for (const key of new Set([...mine.keys(), ...other.keys()])) {
        if (!mine.has(key)) throw new Finding(`${key}: only in ${theirSource}`);
        if (!other.has(key)) throw new Finding(`${key}: missing from ${theirSource}`);
        const difference = firstDifference(mine.get(key), other.get(key), key);
        if (difference) throw new Finding(`ours vs ${theirSource}: ${difference}`);
    }
}

function parseArguments(argv) {
    const options = { kustomize: null, print: false, compare: null, file: null };
    for (let i = 0; i < argv.length; i++) {
        const arg = argv[i];
        if (arg === '--kustomize' && i + 1 < argv.length) {
            options.kustomize = argv[++i];
        } else if (arg === '--compare' && i + 1 < argv.length) {
            options.compare = argv[++i];
        } else if (arg === '--print') {
            options.print = true;
        } else if (!arg.startsWith('--') && options.file === null) {
            options.file = arg;
        } else {
            return null;
        }
    }
    const needsKustomize = options.print || options.compare !== null;
    if (needsKustomize && options.kustomize === null) return null;
    if (options.kustomize !== null && options.file !== null) return null;
    return options;
}

function main() {
    const options = parseArguments(process.argv.slice(2));
    if (options === null) {
        console.error('usage: validate_k8s.js [FILE] | --kustomize DIR [--print | --compare FILE]');
        return 2;
    }
    let entries;
    if (options.kustomize !== null) {
        entries = renderKustomization(options.kustomize);
    } else {
        const source = options.file || '<stdin>';
        entries = parseDocuments(fs.readFileSync(options.file || 0, 'utf8'), source);
    }
    if (options.print) {
        const texts = entries.map((e) => YAML.stringify(e.object, { version: '1.1' }));
        process.stdout.write(texts.join('---\n'));
        return 0;
    }
    if (entries.length === 0) throw new Finding('no resources to validate');
    validate(entries);
    if (options.compare !== null) {
        const theirs = parseDocuments(fs.readFileSync(options.compare, 'utf8'), options.compare);
        validate(theirs);
        compare(entries, theirs, options.compare);
        console.log(`validate_k8s: ok: ${entries.length} resources, same as ${options.compare}`);
        return 0;
    }
    const names = entries.map((e) => `${e.object.kind}/${e.object.metadata.name}`).join(', ');
    console.log(`validate_k8s: ok: ${entries.length} resources valid (${names})`);
    return 0;
}

try {
    process.exitCode = main();
} catch (error) {
    if (!(error instanceof Finding) && error.code !== 'ENOENT') throw error;
    console.error(`validate_k8s: ${error.message}`);
    process.exitCode = 1;
}
