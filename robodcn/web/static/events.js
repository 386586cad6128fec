// The live event stream (GET /v1/events, SSE): state, move and alert events, reconnecting
// with a backoff when the service refuses or restarts.
import { S } from "./state.js";
import { setLink } from "./ui.js";
import { onAlert, onState, setMove } from "./status.js";

export function connect() {
  if (S.es) S.es.close();
  const es = new EventSource("/v1/events");
  S.es = es;
  es.onopen = () => { S.backoff = 1000; setLink("live", true); };
  es.onerror = () => {
    setLink("reconnecting…", false);
    // The browser retries by itself after a dropped stream; after a refusal (503) it gives
    // up (CLOSED): then reconnect here, backing off.
    if (es.readyState === EventSource.CLOSED) {
      setTimeout(() => { if (S.es === es) connect(); }, S.backoff);
      S.backoff = Math.min(2 * S.backoff, 10000);
    }
  };
  es.addEventListener("state", (ev) => onState(JSON.parse(ev.data)));
  es.addEventListener("move", (ev) => { S.stats.move++; setMove(JSON.parse(ev.data)); });
  es.addEventListener("alert", (ev) => { S.stats.alert++; onAlert(JSON.parse(ev.data)); });
}
