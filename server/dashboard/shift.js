// soilvol dashboard: the shift - its totals (GetProduction), its truck loads (ListLoads) with
// their passes stacked against the target and the body scan's reconciliation, a date and shift
// filter, and CSV downloads of production, loads and records.
const DAY_MS = 86400000;
const STATUSES = ["loaded_ok", "underloaded", "overloaded", "loaded", "carryback", "empty"];

let deps = null;      // { api, headers, timeText, fmt, $ } from app.js
let periods = [];     // the chosen date's shifts: ProductionRow (ungrouped)
let pending = null;   // a refresh waiting (events come in bursts)

function localDate(date) {
  const pad = (n) => String(n).padStart(2, "0");
  return `${date.getFullYear()}-${pad(date.getMonth() + 1)}-${pad(date.getDate())}`;
}

function chosen() {
  return periods.find((p) => p.period === deps.$("shift-select").value) || periods[0];
}

async function loadPeriods() {
  const date = deps.$("shift-date").value;
  const day = new Date(`${date}T00:00:00Z`).getTime();
  // A wide range in UTC: the site's zone (the server's) decides which shifts are this date's.
  const start = new Date(day - DAY_MS).toISOString();
  const end = new Date(day + 2 * DAY_MS).toISOString();
  const answer = await deps.api(`/v1/production?startTime=${start}&endTime=${end}` +
                                "&period=PRODUCTION_PERIOD_SHIFT&pageSize=1000");
  const now = Date.now();
  const rows = answer.rows || [];
  if (!deps.$("shift-date").dataset.chosen) {
    // At first the shift running now, whose date (the site's) may be yesterday here.
    const running = rows.find((p) => Date.parse(p.startTime) <= now && now < Date.parse(p.endTime));
    if (running) deps.$("shift-date").value = running.period.slice(0, 10);
  }
  periods = rows.filter((row) => row.period.startsWith(`${deps.$("shift-date").value} `));
  const select = deps.$("shift-select");
  const previous = select.value;
  select.replaceChildren(...periods.map((row) => {
    const option = document.createElement("option");
    option.value = row.period;
    option.textContent = row.period.slice(11);
    return option;
  }));
  const current = periods.find((p) => Date.parse(p.startTime) <= now && now < Date.parse(p.endTime));
  if (periods.some((p) => p.period === previous)) select.value = previous;
  else if (current) select.value = current.period;
  deps.$("shift-zone").textContent = answer.timeZone ? `site time, ${answer.timeZone}` : "";
}

function stripCell(label, value, unit = "") {
  const cell = document.createElement("div");
  cell.className = "strip-cell";
  const number = document.createElement("b");
  number.textContent = value;
  const text = document.createElement("span");
  text.textContent = unit ? `${label} [${unit}]` : label;
  cell.append(number, text);
  return cell;
}

function renderStrip(row) {
  const strip = deps.$("shift-strip");
  if (!row) { strip.replaceChildren(stripCell("no shift", "-")); return; }
  const counts = row.statusCounts || {};
  const cells = [
    stripCell("loads", String(Number(row.loads || 0))),
    stripCell("passes", String(Number(row.passes || 0))),
    stripCell("loose volume", deps.fmt(row.volumeM3 || 0, 2), "m³"),
    stripCell("bank volume", deps.fmt(row.bankVolumeM3 || 0, 2), "m³"),
    stripCell("mass", deps.fmt((row.massKg || 0) / 1000, 1), "t"),
    stripCell("mean fill", deps.fmt(100 * (row.meanFillRatio || 0), 0), "%"),
  ];
  for (const status of STATUSES) {
    if (counts[status]) cells.push(stripCell(status.replace("_", " "), String(Number(counts[status]))));
  }
  strip.replaceChildren(...cells);
  strip.dataset.volume = String(row.volumeM3 || 0);
  strip.dataset.passes = String(Number(row.passes || 0));
  deps.$("shift-range").textContent =
    `${deps.timeText(row.startTime)} - ${deps.timeText(row.endTime)}`;
}

function loadTarget(load) {
  const a = load.assessment || {};
  return a.targetRatio > 0 ? load.volumeM3 / a.targetRatio : null;
}

function renderLoad(load) {
  const box = document.createElement("div");
  box.className = "load";
  box.dataset.loadId = load.loadId;
  const status = ((load.assessment && load.assessment.status) || "").replace("LOAD_STATUS_", "");
  const head = document.createElement("div");
  head.className = "load-head";
  const name = document.createElement("b");
  name.textContent = load.displayName || load.haulUnitId;
  const badge = document.createElement("span");
  badge.className = `badge status-${status.toLowerCase()}`;
  badge.textContent = `${status.toLowerCase().replace("_", " ")} ${deps.fmt(100 * ((load.assessment || {}).statusProbability || 0), 0)}%`;
  const facts = document.createElement("span");
  const closed = load.state === "LOAD_STATE_CLOSED" ? "closed" : "open";
  facts.textContent = `${load.passCount || 0} passes, ${deps.fmt(load.volumeM3 || 0, 2)} m³ ± ` +
                      `${deps.fmt(1000 * (load.uncertaintyM3 || 0), 0)} L, ${closed}`;
  head.append(name, badge, facts);
  // Each pass a segment, on a scale that holds the target and the load.
  const bar = document.createElement("div");
  bar.className = "load-bar";
  const target = loadTarget(load);
  const scale = Math.max(target || 0, load.volumeM3 || 0) * 1.1 || 1;
  for (const pass of load.passes || []) {
    const segment = document.createElement("div");
    segment.className = "pass";
    segment.style.width = `${(100 * (pass.volumeM3 || 0)) / scale}%`;
    segment.title = `${pass.containerId} ${deps.fmt(pass.volumeM3 || 0, 3)} m³ at ${deps.timeText(pass.createTime)}`;
    bar.append(segment);
  }
  if (target) {
    const marker = document.createElement("div");
    marker.className = "target";
    marker.style.left = `${(100 * target) / scale}%`;
    marker.title = `target ${deps.fmt(target, 2)} m³`;
    bar.append(marker);
  }
  box.append(head, bar);
  if (load.reconciliation) {
    const r = load.reconciliation;
    const line = document.createElement("div");
    line.className = `reconcile ${r.withinTwoSigma ? "agrees" : "disagrees"}`;
    line.textContent = `body scan ${deps.fmt(r.bodyVolumeM3, 2)} m³: ${(r.differenceM3 >= 0 ? "+" : "")}` +
      `${deps.fmt(r.differenceM3, 2)} m³ = ${deps.fmt(r.differenceSigmas, 1)} σ ` +
      `(${r.withinTwoSigma ? "agrees with the passes" : "disagrees with the passes"})`;
    box.append(line);
  }
  return box;
}

async function renderLoads(row) {
  const list = deps.$("loads");
  if (!row) { list.replaceChildren(); return; }
  const page = await deps.api("/v1/loads?pageSize=200");
  const start = Date.parse(row.startTime), end = Date.parse(row.endTime);
  const loads = (page.loads || []).filter((l) => {
    const t = Date.parse(l.createTime);
    return t >= start && t < end;
  });
  if (loads.length === 0) {
    const none = document.createElement("p");
    none.className = "muted";
    none.textContent = "no loads in this shift";
    list.replaceChildren(none);
    return;
  }
  list.replaceChildren(...loads.map(renderLoad));
}

export async function refreshShift() {
  try {
    if (periods.length === 0) await loadPeriods();
    const row = chosen();
    renderStrip(row);
    await renderLoads(row);
  } catch (error) {
    deps.$("shift-strip").replaceChildren(stripCell(`shift totals: ${error.message}`, "-"));
  }
}

/// A refresh in a moment: live records come in bursts.
export function shiftChanged() {
  if (pending) return;
  pending = setTimeout(async () => {
    pending = null;
    try { await loadPeriods(); } catch { /* refreshShift shows it */ }
    refreshShift();
  }, 1500);
}

async function download(kind) {
  const row = chosen();
  if (!row) return;
  const range = `startTime=${row.startTime}&endTime=${row.endTime}`;
  const paths = {
    production: `/v1/production:export?${range}&period=PRODUCTION_PERIOD_HOUR&groupBy=PRODUCTION_GROUPING_CONTAINER`,
    loads: "/v1/loads:export",
    estimates: `/v1/containers/-/estimates:export?${range}&registrationId=-`,
  };
  const response = await fetch(paths[kind], { headers: deps.headers() });
  if (!response.ok) throw new Error(`${kind} export: ${response.status}`);
  const link = document.createElement("a");
  link.href = URL.createObjectURL(await response.blob());
  link.download = `soilvol-${kind}-${row.period.replace(/[^0-9A-Za-z-]+/g, "_")}.csv`;
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(link.href), 10000);
}

export function startShift(dependencies) {
  deps = dependencies;
  const date = deps.$("shift-date");
  date.value = localDate(new Date());
  date.addEventListener("change", async () => {
    date.dataset.chosen = "1";
    periods = [];
    await refreshShift();
  });
  deps.$("shift-select").addEventListener("change", () => refreshShift());
  for (const button of document.querySelectorAll("[data-export]")) {
    button.addEventListener("click", () => download(button.dataset.export).catch((e) => deps.showError(e.message)));
  }
  refreshShift();
  setInterval(shiftChanged, 30000);
}
