// What the page shows of the arm and its move: the state readouts, the move's status pill
// with its reason (why a move is degraded, stopped or failed, and its warnings), the
// speed slider following the running move's actual speed scale, the alerts, and which
// controls are enabled.
import { S, $, DEG, ACTIVE, moveActive } from "./state.js";
import { api } from "./api.js";
import { showError } from "./ui.js";
import { redraw } from "./draw.js";
import { poseText } from "./geometry.js";
import { setTarget } from "./plan.js";

/** Follow move `id`: a fresh measured series, and the plan it runs (GET
 * /v1/moves/{id}/trajectory: a replacement's own plan, from its moving start). */
export function trackMove(id) {
  if (S.trackedMove === id) return;
  S.trackedMove = id;
  S.measured = [];
  S.movePlan = null;
  S.movePlanOf = null;
  if (!S.features.moveTrajectory) return;
  api("GET", `/v1/moves/${encodeURIComponent(id)}/trajectory`).then((t) => {
    if (S.trackedMove === id) { S.movePlan = t; S.movePlanOf = id; redraw(); }
  }).catch(() => {});
}

const WORDS = { stopped: "stopped", collision: "collision", fault: "fault" };

/** Why a move ended as it did, in words: the report's headline (a degraded move: how many
 * samples were skipped, and why), the error, and every warning. "" for a clean move. */
export function moveReason(move) {
  const parts = [], report = move.report || null;
  if (move.status === "degraded") {
    const head = (report && report.headline) || "completed with samples skipped";
    const rate = report && typeof report.rate_hz === "number" ? ` ${report.rate_hz} Hz` : "";
    parts.push(`${head} (the stream fell behind its${rate} schedule)`);
  } else if (WORDS[move.status]) {
    const text = (report && report.headline) || (move.error && move.error.message);
    if (text) parts.push(text);
  } else if (move.status === "failed" && move.error) {
    parts.push(move.error.message);
  } else if (move.status === "replaced") {
    parts.push("replaced by a newer move");
  }
  const warnings = [...((report && report.warnings) || []), ...(move.warnings || [])];
  for (const w of warnings) parts.push("warning: " + (typeof w === "string" ? w : w.message || w.code));
  return parts.join("\n");
}

export function setMove(info) {
  if (!info) return;
  if (S.move && Number(info.id) < Number(S.move.id)) return;  // an older move's news
  // A state event read before the move ended may arrive after its end: an ended move stays
  // ended (no status goes back to queued or running).
  if (S.move && info.id === S.move.id && !ACTIVE.includes(S.move.status) &&
      ACTIVE.includes(info.status)) return;
  const was = S.move;
  S.move = { ...(S.move && S.move.id === info.id ? S.move : {}), ...info };
  const move = S.move, el = $("move-status");
  el.textContent = move.status;
  el.className = "pill " + move.status;
  el.dataset.moveId = move.id;
  el.title = `move ${move.id}`;
  $("move-progress").textContent = ACTIVE.includes(move.status) || move.status === "done"
    ? `${Math.round(100 * (move.progress || 0))} %` : "";
  const reason = moveReason(move);
  $("move-reason").textContent = reason;
  $("move-reason").hidden = !reason;
  if (move.status === "failed" && move.error && (!was || was.status !== "failed" || was.id !== move.id)) {
    showError(move.error);
  }
  // The state events carry a short status: an ended move's report comes from its own route.
  if (!ACTIVE.includes(move.status) && !move.report && S.reportAsked !== move.id) {
    S.reportAsked = move.id;
    api("GET", `/v1/moves/${encodeURIComponent(move.id)}`).then(setMove).catch(() => {});
  }
  updateButtons();
}

export function updateButtons() {
  const arm = S.hasArm, active = moveActive(), f = S.features;
  $("move").disabled = !arm || (active && !f.replace);
  $("stop").disabled = !arm;
  $("hold").disabled = !arm;
  $("pause").hidden = !f.pause;
  $("resume").hidden = !f.resume;
  $("pause").disabled = !active;
  // Resume acts on a paused move only: at idle, or while a move runs, it has nothing to do
  const paused = active && !!((S.move && S.move.paused) || (S.state && S.state.paused));
  $("resume").disabled = !arm || !paused;
  $("speed-box").hidden = !f.speed;
  $("speed").disabled = !active;             // it scales the running move only
  $("torque-row").hidden = !f.torque;
  $("gripper-row").hidden = !f.gripper;
  document.querySelectorAll("[data-jog]").forEach((b) => { b.disabled = !arm || (active && !f.replace); });
}

/** Show speed scale k on the slider (not while the user is dragging it). */
export function showSpeed(k) {
  if (S.speedEditing) return;
  $("speed").value = String(k);
  $("speed-value").textContent = `${Math.round(100 * k)} %`;
}

export function onState(st) {
  S.state = st;
  const s = S.stats;
  s.state++;
  s.stamps.push(performance.now());
  if (s.stamps.length > 400) s.stamps.splice(0, s.stamps.length - 400);
  if (!S.target) setTarget(st.pose.slice());
  $("joints").textContent = st.joints.map((q) => (q / DEG).toFixed(1) + "°").join(", ");
  $("pose").textContent = poseText(S.model, st.pose);
  const tq = $("torque-state");
  tq.textContent = st.torque === true ? "torque on" : st.torque === false ? "torque off" : "torque ?";
  tq.className = "pill " + (st.torque ? "ok" : "");
  // The running move's actual speed scale; none runs: the next starts at 100 %.
  showSpeed(typeof st.speed_scale === "number" ? st.speed_scale : 1);
  const mi = st.move_info;
  if (mi) {
    if (ACTIVE.includes(mi.status)) {
      trackMove(mi.id);
      S.measured.push({ t: mi.elapsed || 0, q: st.joints, pose: st.pose, err: mi.tracking_error,
        current: st.current });
    }
    setMove(mi);
  } else if (!!st.paused !== !!S.pausedShown) {
    updateButtons();                      // a pause or resume is in the state's own flag
  }
  S.pausedShown = !!st.paused;
  redraw();
}

export function onAlert(a) {
  const el = $("alerts");
  const parts = Object.entries(a.alerts || {}).map(([id, text]) => `servo ${id}: ${text}`);
  if (a.error) parts.push(a.error.message);
  el.textContent = parts.join("\n");
  el.hidden = !parts.length;
}
