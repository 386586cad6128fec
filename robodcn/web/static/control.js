// The control buttons: Move (a new move, or a retarget of the running one with replace),
// Stop (smooth) and Hold, pause/resume, the speed scale, jogging, torque and the gripper.
import { S, $, DEG, moveActive } from "./state.js";
import { api } from "./api.js";
import { showError, clearError } from "./ui.js";
import { redraw } from "./draw.js";
import { failure, inputsError, planBody, presentPose, readInputs, setTarget } from "./plan.js";
import { setMove, trackMove } from "./status.js";

export async function startMove() {
  if (!readInputs()) { showError(inputsError()); return; }
  clearError();
  const method = $("method").value;
  const body = planBody(method, { fromPresent: true });
  const before = S.state ? S.state.joints.slice() : null;
  const retarget = moveActive() && S.features.replace;
  if (retarget) body.replace = true;
  try {
    const info = await api("POST", "/v1/moves", body);
    S.sent = { id: info.id, pose: body.waypoints[body.waypoints.length - 1].slice() };
    trackMove(info.id);          // loads the move's own plan where the service offers it
    setMove(info);
    if (!S.features.moveTrajectory) {
      // An older service: the same request from the same joints (not exact for a retarget).
      const again = planBody(method);
      if (before && !retarget) again.start_joints = before;
      api("POST", "/v1/trajectories", again).then((t) => {
        if (S.trackedMove === info.id) { S.movePlan = t; redraw(); }
      }).catch(() => {});
    }
  } catch (e) {
    showError(e.error);
    if (e.status === 422) {  // show where the refused plan fails
      // The error's field indexes the body sent (one waypoint: waypoints[0] is the target);
      // a sample is located with the same plan from the present joints.
      const again = planBody(method);
      if (S.state) again.start_joints = S.state.joints;
      S.plans = { [method]: await failure(e.error, body, again) };
      S.planOrder = [method];
      redraw();
    }
  }
}

export async function post(path, body) {
  try { clearError(); return await api("POST", path, body); } catch (e) { showError(e.error); return null; }
}

export function stop(kind) {
  const mode = kind === "hold" ? S.features.holdStop : S.features.smoothStop;
  return post("/v1/stop", mode ? { mode } : {});
}

/** The step of jog direction `dir` ("+x", "-t", "+z", …) on a pose of the arm's axes:
 * `step` metres along x, y or z, 5° of θ or pitch for "t". */
function jogDelta(dir, step) {
  const axis = dir.slice(1), sign = dir[0] === "-" ? -1 : 1;
  const i = axis === "t" ? S.model.angleIndex : S.model.axes.indexOf(axis);
  const d = S.model.axes.map(() => 0);
  if (i >= 0) d[i] = sign * (axis === "t" ? 5 * DEG : step);
  return d;
}

/** Where a jog steps from: the running move's target (retargeted), else the target of the
 * move that just completed when the arm is there (within 1 cm and 5°: the last state event
 * may predate the move's last samples), else the present pose. */
function jogBase() {
  if (moveActive() && S.features.replace && S.target) return S.target.slice();
  const present = presentPose(), sent = S.sent, move = S.move;
  if (sent && move && move.id === sent.id && ["done", "degraded"].includes(move.status)) {
    const a = S.model.angleIndex;
    const dist = Math.hypot(...present.map((v, i) => (i === a ? 0 : v - sent.pose[i])));
    if (dist < 0.01 && Math.abs(present[a] - sent.pose[a]) < 5 * DEG) return sent.pose.slice();
  }
  return present;
}

export function jog(dir) {
  if (moveActive() && !S.features.replace) {
    showError("a move is running: this service cannot retarget it (no \"replace\"); stop it first");
    return;
  }
  const step = (parseFloat($("jog-step").value) || 1) / 100;
  const base = jogBase();
  const d = jogDelta(dir, step);
  setTarget(base.map((v, i) => v + d[i]));
  startMove();
}

export function setSpeed(k) {
  S.speedEditing = true;
  api("PUT", "/v1/speed", { [S.features.speed]: k })
    .catch((e) => showError(e.error))
    .finally(() => { S.speedEditing = false; });
}

/** POST /v1/torque. Off on an arm under gravity the service refuses without confirm (409
 * gravity_release, saying what gravity holds): the page asks the user with those words and
 * sends it again confirmed only when they agree. */
export async function torque(on) {
  const body = { [S.features.torque]: on };
  try {
    clearError();
    return await api("POST", "/v1/torque", body);
  } catch (e) {
    const err = e.error || {};
    if (on || e.status !== 409 || err.code !== "gravity_release" || !S.features.torqueConfirm) {
      showError(err);
      return null;
    }
    if (!window.confirm(`${err.message}.\n\nSwitch torque off?`)) {
      showError({ message: "torque stays on (switching it off was not confirmed)" });
      return null;
    }
    return post("/v1/torque", { ...body, [S.features.torqueConfirm]: true });
  }
}

/** What a gripper command did (the service's answer), in the user's units. */
function showGripper(what, result) {
  const box = $("gripper-state");
  if (!result) { box.textContent = ""; return; }
  const mm = (m) => (1000 * m).toFixed(1);
  const word = { open: "open", close: "closed", width: "set" }[result.command] || what;
  const held = result.blocked ? " · holding an object" : result.settled ? "" : " · not settled";
  const width = typeof result.final_width_m === "number" ? result.final_width_m : null;
  box.textContent = width === null ? word : `${word}: ${mm(width)} mm${held}`;
  box.dataset.widthM = width === null ? "" : String(width);
}

/** POST /v1/gripper: "open", "close" or a width typed in millimetres; the answer is shown
 * beside the buttons. */
export async function gripper(what) {
  let body = { command: what };
  if (what === "width") {
    const mm = parseFloat($("gripper-width").value);
    if (!Number.isFinite(mm)) { showError({ message: "the gripper width must be a number (mm)", field: "width_m" }); return null; }
    body = { width_m: mm / 1000 };
  }
  $("gripper-state").textContent = "…";
  const result = await post("/v1/gripper", body);
  showGripper(what, result);
  return result;
}
