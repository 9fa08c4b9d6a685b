// soilvol dashboard: Server-Sent Events read through fetch (EventSource cannot send a bearer
// token), reconnecting after a second and resuming after the last event id seen.

function parseEvent(block) {
  let id = "", event = "message";
  const data = [];
  for (const line of block.split("\n")) {
    if (line.startsWith(":")) continue;
    const colon = line.indexOf(":");
    const field = colon < 0 ? line : line.slice(0, colon);
    const value = colon < 0 ? "" : line.slice(colon + 1).replace(/^ /, "");
    if (field === "id") id = value;
    else if (field === "event") event = value;
    else if (field === "data") data.push(value);
  }
  return { id, event, data: data.join("\n") };
}

/// Streams `path` for ever: onEvent({id, event, data}) per event, onLive(true|false) as the
/// stream opens and drops. Returns the AbortController that ends it.
export function streamEvents(path, headers, onEvent, onLive = () => {}) {
  const abort = new AbortController();
  let lastId = "";
  (async () => {
    for (;;) {
      try {
        const extra = { Accept: "text/event-stream" };
        if (lastId) extra["Last-Event-ID"] = lastId;
        const response = await fetch(path, { headers: headers(extra), signal: abort.signal });
        if (!response.ok) throw new Error(`${path}: ${response.status}`);
        onLive(true);
        const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
        let buffer = "";
        for (;;) {
          const { value, done } = await reader.read();
          if (done) break;
          buffer += value;
          let end;
          while ((end = buffer.indexOf("\n\n")) >= 0) {
            const event = parseEvent(buffer.slice(0, end));
            buffer = buffer.slice(end + 2);
            if (event.id) lastId = event.id;
            if (event.data) onEvent(event);
          }
        }
      } catch (error) {
        if (abort.signal.aborted) return;
      }
      onLive(false);
      await new Promise((resolve) => setTimeout(resolve, 1000));
      if (abort.signal.aborted) return;
    }
  })();
  return abort;
}
