// soilvol dashboard: the alerts panel - the newest alerts (ListAlerts), then each new one as it
// is raised (/v1/alerts:watch), its kind, time, container or load and message.
import { streamEvents } from "./sse.js";

const SHOWN = 20;
const KIND_TEXT = {
  ALERT_KIND_OVERLOAD: "overload",
  ALERT_KIND_CARRYBACK: "carryback",
  ALERT_KIND_REFUSED_SCANS: "refused scans",
  ALERT_KIND_LOW_COVERAGE: "low coverage",
  ALERT_KIND_LOAD_OFF_TARGET: "load off target",
};

let deps = null;  // { api, headers, timeText, $ } from app.js
let alerts = [];  // newest first
let stream = null;

function renderAlert(alert, fresh) {
  const item = document.createElement("li");
  item.className = `alert alert-${(KIND_TEXT[alert.kind] || "other").replace(/ /g, "-")}`;
  if (fresh) item.classList.add("fresh");
  const kind = document.createElement("span");
  kind.className = "badge";
  kind.textContent = KIND_TEXT[alert.kind] || alert.kind;
  const time = document.createElement("time");
  time.dateTime = alert.createTime;
  time.textContent = deps.timeText(alert.createTime, "time");
  time.title = deps.timeText(alert.createTime);
  const text = document.createElement("span");
  text.className = "alert-message";
  text.textContent = alert.message;
  item.append(kind, time, text);
  return item;
}

function render(freshId = "") {
  const list = deps.$("alerts");
  if (alerts.length === 0) {
    const none = document.createElement("li");
    none.className = "muted";
    none.textContent = "no alerts";
    list.replaceChildren(none);
    return;
  }
  list.replaceChildren(...alerts.map((a) => renderAlert(a, a.alertId === freshId)));
}

export async function refreshAlerts() {
  try {
    const answer = await deps.api(`/v1/alerts?pageSize=${SHOWN}`);
    alerts = answer.alerts || [];
    render();
  } catch (error) {
    const item = document.createElement("li");
    item.className = "muted";
    item.textContent = `alerts: ${error.message}`;
    deps.$("alerts").replaceChildren(item);
  }
}

export function startAlerts(dependencies) {
  deps = dependencies;
  if (stream) stream.abort();
  refreshAlerts().then(() => {
    stream = streamEvents("/v1/alerts:watch", deps.headers, (event) => {
      if (event.event !== "alert") return;
      const alert = JSON.parse(event.data);
      if (alerts.some((a) => a.alertId === alert.alertId)) return;
      alerts = [alert, ...alerts].slice(0, SHOWN);
      render(alert.alertId);
    });
  });
}
