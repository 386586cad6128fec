// Dragging the target moves the arm live: a follow session in pose space (POST /v1/follow
// {"space": "pose"}) opened on pointer-down, the dragged pose sent as the session's target
// (PUT /v1/follow/target) at most every FOLLOW_PERIOD_MS — one request in flight, the newest
// pose replacing any not yet sent, so no stale target is ever queued — and ended on
// pointer-up (DELETE /v1/follow: the arm comes to rest at the last target). A refused pose
// (422 naming `pose`: out of reach, in a keep-out zone) shows in the error line while the arm
// goes on to the previous target. Stop and Hold end the session on the service (POST
// /v1/stop); the targets still to send then find none (409) and are dropped.
import { S, moveActive } from "./state.js";
import { api } from "./api.js";
import { clearError, showError } from "./ui.js";
import { setMove, trackMove } from "./status.js";

/** Least time between two targets sent (ms): about 30 Hz, a teleoperation stream's pace. */
export const FOLLOW_PERIOD_MS = 30;

/** The session of the drag in progress (null between drags). */
let drag = null;

/** Whether a drag may follow live: the service offers follow sessions (follow_open in its
 * OpenAPI document), an arm is attached and no other move runs. */
export function canFollow() {
  return !!(S.features.follow && S.hasArm && S.state && !moveActive());
}

/** Pointer-down on the target: a drag that may follow (false when it cannot, and the drop
 * previews instead). The session opens at the drag's first move, so that a click alone
 * moves nothing. */
export function followStart() {
  drag = canFollow() ? { open: false, ready: false, pending: null, busy: false,
    sentAt: -Infinity, timer: null, ending: false, closed: false, gone: false, id: null,
    taken: null } : null;
  return drag !== null;
}

function open(s) {
  s.open = true;
  api("POST", "/v1/follow", { space: "pose" }).then((info) => {
    s.ready = true;
    s.id = info.id;
    trackMove(info.id);
    setMove(info);
    pump(s);
  }).catch((e) => {
    s.gone = true;
    showError(e.error, "follow");
  });
}

/** The dragged target moved to `pose` (the arm's pose axes, SI). */
export function followTarget(pose) {
  if (!drag) return;
  drag.pending = pose.slice();
  if (!drag.open) open(drag);
  pump(drag);
}

/** Pointer-up: send the last target, then end the session (rest there). False when the
 * drag opened no session (it could not follow, or it never moved). */
export function followEnd() {
  const s = drag;
  drag = null;
  if (!s || !s.open) return false;
  s.ending = true;
  pump(s);
  return true;
}

/** Send what is due: the newest pending target once the last request answered and the
 * period since it was sent is over; with none left on a drag that ended, the end. */
function pump(s) {
  if (!s.ready || s.busy || s.gone) return;
  if (s.pending === null) {
    if (s.ending && !s.closed) close(s);
    return;
  }
  const wait = FOLLOW_PERIOD_MS - (performance.now() - s.sentAt);
  if (wait > 0) {
    if (s.timer === null) s.timer = setTimeout(() => { s.timer = null; pump(s); }, wait);
    return;
  }
  const pose = s.pending;
  s.pending = null;
  s.busy = true;
  s.sentAt = performance.now();
  api("PUT", "/v1/follow/target", { pose }).then(() => {
    s.taken = pose;
    clearError("follow");                  // a refused pose no longer stands
  }).catch((e) => {
    if (e.status === 409) s.gone = true;   // the session ended (a Stop, a timeout, a fault)
    else showError(e.error, "follow");
  }).finally(() => {
    s.busy = false;
    pump(s);
  });
}

/** The page closing mid-drag (a tab closed, a reload): the session ends as on a drop, so
 * that it does not hold the arm against every later move. */
window.addEventListener("pagehide", () => {
  const s = drag;
  drag = null;
  if (s && s.ready && !s.closed && !s.gone) close(s, true);
});

function close(s, keepalive = false) {
  s.closed = true;
  // where the arm comes to rest: jogging goes on from there (control.js: jogBase)
  if (s.taken) S.sent = { id: s.id, pose: s.taken.slice() };
  api("DELETE", "/v1/follow", {}, { keepalive }).then(setMove).catch((e) => {
    if (e.status !== 409) showError(e.error, "follow");   // 409: it had ended already
  });
}
