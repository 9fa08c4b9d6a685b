// soilvol dashboard: plain JavaScript over the REST gateway (same origin), no build step.
// Containers with their last load (fill gauge, status), live updates from
// GET /v1/estimates:watch (Server-Sent Events read through fetch, so that a bearer token can go
// with it), the selected container's heightmap, distribution and history, and an upload form;
// the shift's totals and truck loads are shift.js's, the alerts panel alerts.js's.

import { startShift, shiftChanged } from "./shift.js";
import { startAlerts } from "./alerts.js";
import { streamEvents } from "./sse.js";

const state = {
  containers: new Map(),   // id -> Container
  estimates: new Map(),    // id -> [Estimate] newest first (BASIC view)
  selected: null,
  watchAbort: null,
};

const $ = (id) => document.getElementById(id);
const token = () => localStorage.getItem("soilvol.token") || "";
const STATUS = (s) => (s || "LOAD_STATUS_UNSPECIFIED").replace("LOAD_STATUS_", "");
const fmt = (v, d) => (v === undefined || v === null || Number.isNaN(v)) ? "-" : Number(v).toFixed(d);

// Times in one zone, named on the page: the browser's own, or one chosen in the header (kept in
// this browser).
const BROWSER_ZONE = Intl.DateTimeFormat().resolvedOptions().timeZone || "UTC";
const zone = () => localStorage.getItem("soilvol.zone") || BROWSER_ZONE;
function timeText(iso, parts = "datetime") {
  const options = { timeZone: zone(), hour: "2-digit", minute: "2-digit", hourCycle: "h23" };
  if (parts !== "minutes") options.second = "2-digit";
  if (parts === "datetime" || parts === "day") {
    Object.assign(options, { year: "numeric", month: "2-digit", day: "2-digit" });
  }
  if (parts === "datetime") options.timeZoneName = "short";
  return new Intl.DateTimeFormat(undefined, options).format(new Date(iso));
}
function zoneOffsetText() {
  const part = new Intl.DateTimeFormat("en-US", { timeZone: zone(), timeZoneName: "shortOffset" })
    .formatToParts(new Date()).find((p) => p.type === "timeZoneName");
  return part ? part.value : "";
}

// A container's records of its current registration (Container.registrationId): the history of
// a container registered again starts anew.
function estimatesOf(container) {
  const list = state.estimates.get(container.containerId) || [];
  if (!container.registrationId) return list;
  return list.filter((e) => !e.result.registrationId || e.result.registrationId === container.registrationId);
}

function headers(extra = {}) {
  const h = { ...extra };
  if (token()) h.Authorization = `Bearer ${token()}`;
  return h;
}

function showError(message) {
  const box = $("error");
  if (!message) { box.classList.add("hidden"); return; }
  box.textContent = message;
  box.classList.remove("hidden");
}

async function api(path, options = {}) {
  const response = await fetch(path, { ...options, headers: headers(options.headers) });
  const text = await response.text();
  let body = {};
  try { body = text ? JSON.parse(text) : {}; } catch { body = { message: text }; }
  if (!response.ok) {
    const error = new Error(`${response.status}: ${body.message || response.statusText}`);
    error.status = response.status;
    throw error;
  }
  return body;
}

async function listAll(path, key) {
  const all = [];
  let pageToken = "";
  do {
    const sep = path.includes("?") ? "&" : "?";
    const page = await api(`${path}${sep}pageSize=1000${pageToken ? `&pageToken=${encodeURIComponent(pageToken)}` : ""}`);
    all.push(...(page[key] || []));
    pageToken = page.nextPageToken || "";
  } while (pageToken && all.length < 5000);
  return all;
}

// ----------------------------------------------------------------------------------------------
// Data

async function loadContainers() {
  const containers = await listAll("/v1/containers", "containers");
  state.containers = new Map(containers.map((c) => [c.containerId, c]));
}

async function loadEstimates() {
  // Newest first across every container: the last loads of each.
  const page = await api("/v1/containers/-/estimates?pageSize=1000");
  state.estimates = new Map();
  for (const e of page.estimates || []) addEstimate(e, false);
}

function addEstimate(estimate, newest) {
  const list = state.estimates.get(estimate.containerId) || [];
  if (list.some((e) => e.estimateId === estimate.estimateId)) return;
  if (newest) list.unshift(estimate); else list.push(estimate);
  if (list.length > 200) list.length = 200;
  state.estimates.set(estimate.containerId, list);
}

async function refresh() {
  try {
    await loadContainers();
    await loadEstimates();
    showError("");
  } catch (error) {
    const auth = error.status === 401 || error.status === 403;
    showError(auth ? `${error.message} - this server asks for a token` : error.message);
    if (auth) $("token-panel").classList.remove("hidden");
  }
  renderCards();
  if (state.selected) renderDetail();
}

// ----------------------------------------------------------------------------------------------
// Fleet cards

function targetOf(container) {
  const t = container.loadTargets || {};
  if (t.volumeM3) return { volume: t.volumeM3, under: t.underTolerance ?? 0.05, over: t.overTolerance ?? 0.05 };
  if (t.payloadKg && container.material && container.material.densityKgM3) {
    return { volume: t.payloadKg / container.material.densityKgM3, under: t.underTolerance ?? 0.05,
             over: t.overTolerance ?? 0.05, payload: t.payloadKg };
  }
  return null;
}

function gaugeScale(container) {
  const target = targetOf(container);
  return target ? target.volume * (1 + target.over) * 1.15 : (container.heapedCapacityM3 || container.struckCapacityM3 || 1);
}

function renderCards() {
  const cards = $("cards");
  cards.textContent = "";
  if (state.containers.size === 0) {
    cards.innerHTML = '<p class="muted">No containers yet: register one below or through the API.</p>';
    return;
  }
  for (const container of [...state.containers.values()].sort((a, b) =>
    (a.displayName || a.containerId).localeCompare(b.displayName || b.containerId))) {
    const last = estimatesOf(container)[0];
    const card = document.createElement("article");
    card.className = "card" + (state.selected === container.containerId ? " selected" : "");
    card.dataset.container = container.containerId;
    const status = last ? STATUS(last.result.load && last.result.load.status) : "NONE";
    const volume = last ? last.result.volumeM3 : 0;
    const scale = gaugeScale(container);
    const target = targetOf(container);
    const labels = Object.entries(container.labels || {}).map(([k, v]) => `${k}=${v}`).join(" ");
    card.innerHTML = `
      <h3></h3><div class="id"></div><div class="labels"></div>
      <div class="gauge"><div class="band"></div><div class="fill"></div></div>
      <div class="numbers"><span class="volume"></span><span class="badge"></span></div>
      <div class="numbers muted"><span class="mass"></span><span class="when"></span></div>
      <p class="warning hidden" role="note"><span></span></p>`;
    card.querySelector("h3").textContent = container.displayName || container.containerId;
    const warnings = container.warnings || [];
    if (warnings.length) {
      // The first clause on the card ("the struck capacity's 1-sigma is ..."), all in details.
      const note = card.querySelector(".warning");
      note.querySelector("span").textContent = `⚠ ${warnings[0].split(": ")[0]}`;
      note.title = warnings.join("\n");
      note.classList.remove("hidden");
      card.classList.add("warned");
    }
    card.querySelector(".id").textContent = container.displayName ? container.containerId : "";
    card.querySelector(".labels").textContent = labels;
    const fill = card.querySelector(".gauge .fill");
    fill.style.width = `${Math.max(0, Math.min(100, 100 * volume / scale))}%`;
    fill.style.background = `var(--${{ EMPTY: "empty", CARRYBACK: "carryback", UNDERLOADED: "under",
      LOADED_OK: "ok", OVERLOADED: "over", LOADED: "loaded" }[status] || "empty"})`;
    const band = card.querySelector(".gauge .band");
    if (target) {
      band.style.left = `${100 * target.volume * (1 - target.under) / scale}%`;
      band.style.width = `${100 * target.volume * (target.under + target.over) / scale}%`;
    } else {
      band.classList.add("hidden");
    }
    card.querySelector(".volume").textContent = last
      ? `${fmt(volume, 3)} m³${target ? ` of ${fmt(target.volume, 2)}` : ""}` : "no loads yet";
    const badge = card.querySelector(".badge");
    badge.textContent = status === "NONE" ? "no loads" : status.replace("_", " ");
    badge.classList.add(status);
    card.querySelector(".mass").textContent = last && last.result.massKg !== undefined
      ? `${fmt(last.result.massKg / 1000, 2)} t` : "";
    card.querySelector(".when").textContent = last ? timeAgo(last.createTime) : "";
    card.addEventListener("click", () => select(container.containerId));
    cards.appendChild(card);
  }
}

function timeAgo(iso) {
  const seconds = Math.max(0, (Date.now() - Date.parse(iso)) / 1000);
  if (seconds < 60) return `${Math.round(seconds)} s ago`;
  if (seconds < 3600) return `${Math.round(seconds / 60)} min ago`;
  if (seconds < 86400) return `${Math.round(seconds / 3600)} h ago`;
  return timeText(iso, "day").split(",")[0];
}

// ----------------------------------------------------------------------------------------------
// Detail: heightmap, facts, distribution, history

async function select(containerId) {
  state.selected = containerId;
  history.replaceState(null, "", `#${encodeURIComponent(containerId)}`);
  renderCards();
  await renderDetail();
}

async function renderDetail() {
  const container = state.containers.get(state.selected);
  if (!container) { $("detail").classList.add("hidden"); return; }
  $("detail").classList.remove("hidden");
  $("detail-title").textContent = container.displayName || container.containerId;
  const list = estimatesOf(container);
  const last = list[0];
  const badge = $("detail-status");
  const status = last ? STATUS(last.result.load && last.result.load.status) : "NONE";
  badge.className = `badge ${status}`;
  badge.textContent = last ? status.replace("_", " ") : "no loads yet";
  renderWarnings(container);
  renderFacts(container, last);
  renderHistory(container, list);
  renderRecent(list);
  if (last) {
    try {
      const full = await api(`/v1/containers/${encodeURIComponent(container.containerId)}/estimates/${last.estimateId}`);
      if (state.selected === container.containerId) renderHeightmap(full.result);
    } catch (error) {
      showError(error.message);
    }
  } else {
    clearCanvas($("heightmap"));
    $("heightmap-caption").textContent = "";
  }
}

// What the registration could not know (Container.warnings), in full, above the facts.
function renderWarnings(container) {
  const box = $("detail-warnings");
  box.textContent = "";
  const warnings = container.warnings || [];
  box.classList.toggle("hidden", warnings.length === 0);
  for (const warning of warnings) {
    const p = document.createElement("p");
    p.textContent = `⚠ ${warning}`;
    box.append(p);
  }
}

function capacityText(container) {
  const sigma = container.struckCapacityUncertaintyM3 || 0;
  return `${fmt(container.struckCapacityM3, 3)} m³ ± ${fmt(1000 * sigma, 1)} L (1σ)`;
}

function sourceText(container) {
  const kind = (container.registeredFrom || "SCAN_KIND_UNSPECIFIED").replace("SCAN_KIND_", "").toLowerCase();
  return container.hasMesh && kind !== "mesh" ? `${kind} + mesh` : kind;
}

function renderFacts(container, last) {
  const facts = $("facts");
  facts.textContent = "";
  const add = (name, value) => {
    const dt = document.createElement("dt"); dt.textContent = name;
    const dd = document.createElement("dd"); dd.textContent = value;
    facts.append(dt, dd);
  };
  const r = last ? last.result : null;
  add("volume", r ? `${fmt(r.volumeM3, 3)} m³ ± ${fmt(1000 * r.uncertaintyM3, 0)} L` : "-");
  if (r && r.load && r.load.targetRatio !== undefined) add("of target", `${fmt(100 * r.load.targetRatio, 1)} %`);
  if (r && r.load) add("status confidence", `${fmt(100 * r.load.statusProbability, 0)} %`);
  if (r && r.massKg !== undefined) add("mass", `${fmt(r.massKg, 0)} kg`);
  add("fill of struck", r ? `${fmt(100 * r.fillRatio, 1)} %` : "-");
  add("struck capacity", capacityText(container));
  add("heaped (SAE)", `${fmt(container.heapedCapacityM3, 3)} m³`);
  add("registered from", sourceText(container));
  const m = container.material;
  if (m && (m.name || m.densityKgM3)) add("material", `${m.name || ""} ${m.densityKgM3 ? `${m.densityKgM3} kg/m³` : ""}`);
  if (r && r.coverage) add("scan saw", `${fmt(100 * r.coverage.scanObservedShare, 0)} % of the opening`);
  if (last) add("measured", timeText(last.createTime));
  const d = r && r.distribution;
  $("share-x").style.width = `${100 * (d ? d.positiveXShare : 0.5)}%`;
  $("share-y").style.width = `${100 * (d ? d.positiveYShare : 0.5)}%`;
}

// Viridis, sampled: 0 (low) .. 1 (high).
const VIRIDIS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
function colour(t) {
  const x = Math.max(0, Math.min(1, t)) * (VIRIDIS.length - 1);
  const i = Math.min(VIRIDIS.length - 2, Math.floor(x));
  const f = x - i;
  return VIRIDIS[i].map((c, k) => Math.round(c + f * (VIRIDIS[i + 1][k] - c)));
}

function clearCanvas(canvas) {
  canvas.getContext("2d").clearRect(0, 0, canvas.width, canvas.height);
}

function decodeHeights(heightmap) {
  const bytes = Uint8Array.from(atob(heightmap.heightsF32le || ""), (c) => c.charCodeAt(0));
  const view = new DataView(bytes.buffer);
  const heights = new Float32Array(bytes.length / 4);
  for (let i = 0; i < heights.length; ++i) heights[i] = view.getFloat32(4 * i, true);
  return heights;
}

function renderHeightmap(result) {
  const canvas = $("heightmap");
  const ctx = canvas.getContext("2d");
  clearCanvas(canvas);
  const h = result.heightmap;
  if (!h || !h.cols || !h.rows) { $("heightmap-caption").textContent = "no heightmap"; return; }
  const heights = decodeHeights(h);
  // Colours span the observed heights (at least 5 cm), so that an uneven load shows.
  let low = Infinity, high = -Infinity;
  for (const v of heights) if (!Number.isNaN(v)) { low = Math.min(low, v); high = Math.max(high, v); }
  if (low === Infinity) { low = 0; high = 0; }
  const span = Math.max(0.05, high - low);
  const size = Math.min(canvas.width / h.cols, canvas.height / h.rows);
  const x0 = (canvas.width - size * h.cols) / 2;
  const y0 = (canvas.height - size * h.rows) / 2;
  for (let row = 0; row < h.rows; ++row) {
    for (let col = 0; col < h.cols; ++col) {
      const v = heights[row * h.cols + col];
      if (Number.isNaN(v)) continue;  // outside the opening, or not observed
      const [r, g, b] = colour((v - low) / span);
      ctx.fillStyle = `rgb(${r},${g},${b})`;
      // +y up: row 0 (min y) at the bottom.
      ctx.fillRect(x0 + col * size, y0 + (h.rows - 1 - row) * size, Math.ceil(size), Math.ceil(size));
    }
  }
  const d = result.distribution;
  if (d) {  // the load centre
    const cx = x0 + ((d.centreXM - h.originXM) / h.cellM) * size;
    const cy = y0 + (h.rows - (d.centreYM - h.originYM) / h.cellM) * size;
    ctx.strokeStyle = "#fff"; ctx.lineWidth = 3;
    ctx.beginPath(); ctx.arc(cx, cy, 7, 0, 2 * Math.PI); ctx.stroke();
    ctx.strokeStyle = "#c53030"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(cx - 10, cy); ctx.lineTo(cx + 10, cy); ctx.moveTo(cx, cy - 10); ctx.lineTo(cx, cy + 10); ctx.stroke();
  }
  $("heightmap-scale").style.background =
    `linear-gradient(to right, ${VIRIDIS.map((c) => `rgb(${c.join(",")})`).join(", ")})`;
  const ticks = $("heightmap-ticks");
  ticks.textContent = "";
  for (const v of [low, low + span / 2, low + span]) {
    const tick = document.createElement("span");
    tick.textContent = `${fmt(100 * v, 0)} cm`;
    ticks.append(tick);
  }
  $("heightmap-caption").textContent =
    `soil height ${fmt(100 * low, 0)} - ${fmt(100 * (low + span), 0)} cm over the empty surface;` +
    ` ${h.cols} x ${h.rows} cells of ${fmt(100 * h.cellM, 1)} cm; + load centre`;
}

function renderHistory(container, list) {
  const canvas = $("history");
  const ctx = canvas.getContext("2d");
  clearCanvas(canvas);
  const points = list.slice(0, 50).reverse();
  const target = targetOf(container);
  $("history-caption").textContent = `volume [m³] of the last ${points.length} loads` +
    (target ? `; the target band (${fmt(target.volume, 2)} m³ -${fmt(100 * target.under, 0)} / ` +
      `+${fmt(100 * target.over, 0)} %) shaded` : "; no target set");
  const pad = { left: 46, right: 10, top: 10, bottom: 24 };
  const w = canvas.width - pad.left - pad.right;
  const h = canvas.height - pad.top - pad.bottom;
  let top = target ? target.volume * (1 + target.over) * 1.1 : 0.001;
  for (const e of points) top = Math.max(top, e.result.volumeM3 * 1.1);
  const y = (v) => pad.top + h - (v / top) * h;
  // Along time: the first and last loads at the ends.
  const times = points.map((e) => Date.parse(e.createTime));
  const t0 = times[0], t1 = times[times.length - 1];
  const x = (i) => pad.left + (points.length <= 1 || t1 === t0 ? w / 2 : ((times[i] - t0) / (t1 - t0)) * w);
  ctx.font = "11px system-ui, sans-serif";
  ctx.fillStyle = "#6b746f";
  ctx.strokeStyle = "#d9ddd8";
  for (let k = 0; k <= 4; ++k) {
    const v = (top * k) / 4;
    ctx.beginPath(); ctx.moveTo(pad.left, y(v)); ctx.lineTo(pad.left + w, y(v)); ctx.stroke();
    ctx.fillText(`${fmt(v, 2)}`, 4, y(v) + 4);
  }
  ctx.fillText("m³", 4, pad.top + h + 18);
  if (target) {
    ctx.fillStyle = "rgba(47, 133, 90, .15)";
    const hi = y(target.volume * (1 + target.over));
    ctx.fillRect(pad.left, hi, w, y(target.volume * (1 - target.under)) - hi);
  }
  if (points.length === 0) return;
  ctx.strokeStyle = "#4a5d53"; ctx.lineWidth = 1.5;
  ctx.beginPath();
  points.forEach((e, i) => (i ? ctx.lineTo(x(i), y(e.result.volumeM3)) : ctx.moveTo(x(i), y(e.result.volumeM3))));
  ctx.stroke();
  const css = getComputedStyle(document.documentElement);
  for (const [i, e] of points.entries()) {
    const status = STATUS(e.result.load && e.result.load.status);
    const name = { EMPTY: "empty", CARRYBACK: "carryback", UNDERLOADED: "under", LOADED_OK: "ok",
                   OVERLOADED: "over", LOADED: "loaded" }[status] || "empty";
    ctx.fillStyle = css.getPropertyValue(`--${name}`).trim() || "#888";
    ctx.beginPath(); ctx.arc(x(i), y(e.result.volumeM3), 3.5, 0, 2 * Math.PI); ctx.fill();
  }
  // The ends' times, as precise as their span needs, and the zone.
  const span = t1 - t0;
  const parts = span >= 86400e3 ? "day" : span >= 3600e3 ? "minutes" : "seconds";
  const firstLabel = timeText(points[0].createTime, parts);
  const lastLabel = `${timeText(points[points.length - 1].createTime, parts)} ${zoneOffsetText()}`;
  ctx.fillStyle = "#6b746f";
  ctx.fillText(firstLabel, pad.left, canvas.height - 6);
  if (points.length > 1) ctx.fillText(lastLabel, pad.left + w - ctx.measureText(lastLabel).width, canvas.height - 6);
  canvas.dataset.axis = points.length > 1 ? `${firstLabel} | ${lastLabel}` : firstLabel;
}

function renderRecent(list) {
  const body = $("recent").querySelector("tbody");
  body.textContent = "";
  for (const e of list.slice(0, 10)) {
    const row = document.createElement("tr");
    const status = STATUS(e.result.load && e.result.load.status);
    for (const text of [timeText(e.createTime), fmt(e.result.volumeM3, 3),
      fmt(1000 * e.result.uncertaintyM3, 0), e.result.massKg !== undefined ? fmt(e.result.massKg, 0) : "-",
      null, e.requestId || "-"]) {
      const cell = document.createElement("td");
      if (text === null) {
        const badge = document.createElement("span");
        badge.className = `badge ${status}`;
        badge.textContent = status.replace("_", " ");
        cell.appendChild(badge);
      } else {
        cell.textContent = text;
      }
      row.appendChild(cell);
    }
    body.appendChild(row);
  }
}

// ----------------------------------------------------------------------------------------------
// Live updates: Server-Sent Events over fetch (EventSource cannot send a bearer token)

function setLive(on, text) {
  const live = $("live");
  live.className = `live ${on ? "on" : "off"}`;
  live.textContent = text;
}

function watch() {
  if (state.watchAbort) state.watchAbort.abort();
  state.watchAbort = streamEvents("/v1/estimates:watch", headers, handleEvent,
                                  (on) => setLive(on, on ? "live" : "reconnecting"));
}

function handleEvent({ event, data }) {
  if (event !== "estimate") return;
  const estimate = JSON.parse(data);
  addEstimate(estimate, true);
  shiftChanged();
  if (!state.containers.has(estimate.containerId)) {
    refresh();
    return;
  }
  renderCards();
  if (state.selected === estimate.containerId) renderDetail();
}

// ----------------------------------------------------------------------------------------------
// Upload

function parseCorners(text) {
  const corners = text.split(";").map((c) => c.split(",").map(Number));
  if (corners.length !== 4 || corners.some((c) => c.length !== 3 || c.some(Number.isNaN))) {
    throw new Error("corners: four x,y,z separated by ;");
  }
  return { corners: corners.map(([x, y, z]) => ({ x, y, z })) };
}

async function upload(event) {
  event.preventDefault();
  const form = event.target;
  const data = new FormData(form);
  const id = data.get("container");
  const result = $("upload-result");
  try {
    const body = new FormData();
    if (data.get("kind") === "register") {
      const request = { containerId: id, opening: parseCorners(data.get("corners") || "") };
      if (data.get("displayName")) request.displayName = data.get("displayName");
      if (data.get("density")) request.material = { densityKgM3: Number(data.get("density")) };
      if (data.get("target")) request.loadTargets = { volumeM3: Number(data.get("target")) };
      body.append("request", new Blob([JSON.stringify(request)], { type: "application/json" }));
      body.append("cloud", data.get("cloud"));
      const container = await api("/v1/containers", { method: "POST", body });
      result.textContent = `registered ${container.containerId}: struck ${capacityText(container)}` +
        (container.warnings && container.warnings.length ? ` - ⚠ ${container.warnings.join(" ")}` : "");
      await refresh();
    } else {
      body.append("cloud", data.get("cloud"));
      const estimate = await api(`/v1/containers/${encodeURIComponent(id)}:estimate`, { method: "POST", body });
      result.textContent = `${fmt(estimate.volumeM3, 3)} m³, ${STATUS(estimate.load && estimate.load.status)}`;
    }
    showError("");
  } catch (error) {
    result.textContent = "";
    showError(error.message);
  }
}

// ----------------------------------------------------------------------------------------------

function startZone() {
  const select = $("zone");
  for (const name of [...new Set([BROWSER_ZONE, "UTC", zone()])]) {
    const option = document.createElement("option");
    option.value = name;
    option.textContent = name === BROWSER_ZONE ? `${name} (this device)` : name;
    select.append(option);
  }
  select.value = zone();
  select.addEventListener("change", () => {
    localStorage.setItem("soilvol.zone", select.value);
    renderCards();
    if (state.selected) renderDetail();
  });
}

function start() {
  startZone();
  startShift({ api, headers, timeText, fmt, $, showError });
  startAlerts({ api, headers, timeText, $ });
  $("token-button").addEventListener("click", () => $("token-panel").classList.toggle("hidden"));
  $("token-save").addEventListener("click", () => {
    localStorage.setItem("soilvol.token", $("token-input").value.trim());
    $("token-panel").classList.add("hidden");
    refresh().then(() => watch());
    startAlerts({ api, headers, timeText, $ });
  });
  const form = $("upload-form");
  form.addEventListener("submit", upload);
  form.addEventListener("change", () =>
    form.classList.toggle("registering", new FormData(form).get("kind") === "register"));
  api("/v1/info").then((info) => { $("server-version").textContent = `server ${info.version}`; })
    .catch(() => {});
  refresh().then(() => {
    // The container in the address (#truck-7), else the one measured last.
    const wanted = decodeURIComponent(location.hash.slice(1));
    let first = state.containers.has(wanted) ? wanted : null;
    if (!first) {
      let newest = "";
      for (const [id, list] of state.estimates) {
        if (list[0] && list[0].createTime > newest) { newest = list[0].createTime; first = id; }
      }
    }
    if (!first && state.containers.size) first = [...state.containers.keys()][0];
    if (first) select(first);
    watch();
  });
  // Registrations are not events: the fleet is read again now and then.
  setInterval(async () => {
    try { await loadContainers(); renderCards(); } catch { /* shown by the next refresh */ }
  }, 5000);
  setInterval(renderCards, 30000);  // "x min ago"
}

start();
