// The plan form: the target pose (inputs ↔ S.target), the plan request built from it, and
// the preview of every chosen method (POST /v1/trajectories) with where an infeasible plan
// fails.
import { S, $, DEG } from "./state.js";
import { api } from "./api.js";
import { redraw } from "./draw.js";
import { showPlans } from "./plan_table.js";
import { clearError } from "./ui.js";

/** The target-pose input of each pose axis (x, y, theta | x, y, z, pitch). */
function input(axis) {
  return $("target-" + axis);
}

function isAngle(axis) {
  return axis === "theta" || axis === "pitch";
}

export function setTarget(pose, { fromInputs = false } = {}) {
  S.target = pose;
  if (!fromInputs) {
    S.model.axes.forEach((axis, i) => {
      input(axis).value = isAngle(axis) ? (pose[i] / DEG).toFixed(1) : pose[i].toFixed(3);
    });
  }
  redraw();
}

/** The typed target into S.target; false when a field is not a number. */
export function readInputs() {
  const values = S.model.axes.map((axis) => parseFloat(input(axis).value) * (isAngle(axis) ? DEG : 1));
  if (!values.every(Number.isFinite)) return false;
  setTarget(values, { fromInputs: true });
  return true;
}

/** What the error line says when readInputs() fails. */
export function inputsError() {
  const names = S.model.axes.map((a) => ({ theta: "θ" }[a] || a));
  return { message: `${names.slice(0, -1).join(", ")} and ${names[names.length - 1]} must be numbers`,
    field: "target" };
}

export function presentPose() {
  return S.state ? S.state.pose.slice() : S.home.slice();
}

function duration() {
  const v = $("duration").value.trim();
  if (v === "" || v === "auto") return "auto";
  const d = Number(v);
  return Number.isFinite(d) ? d : v;  // the service names a bad value
}

/** The tool speed field in m/s (it reads mm/s): null when empty (the arm's own limit) or
 * when the service takes no tool_speed; a value that is not a number is sent as typed (the
 * service names it). */
function toolSpeed() {
  if (!S.features.toolSpeed) return null;
  const v = $("tool-speed").value.trim();
  if (v === "") return null;
  const mm = Number(v);
  return Number.isFinite(mm) ? mm / 1000 : v;
}

/** The plan request of `method` from the present pose to the target; `fromPresent`: one
 * waypoint (the service starts from the arm's present state) where the contract allows. */
export function planBody(method, { fromPresent = false } = {}) {
  const waypoints = fromPresent && S.features.oneWaypoint ? [S.target.slice()]
    : [presentPose(), S.target.slice()];
  const body = { waypoints, method, duration: duration() };
  if (method === "kenlerp") body.beta = parseFloat($("beta").value);
  const tool = toolSpeed();
  if (tool !== null) body.tool_speed = tool;
  return body;
}

let previewTimer = null;
/** A user's edit of the request: what an earlier Move or operation was refused for no
 * longer stands (cleared now), and a preview of the new request follows. */
export function schedulePreview() {
  clearError();
  clearTimeout(previewTimer);
  previewTimer = setTimeout(preview, 250);
}

function markOf(error, body) {
  // Where an infeasible plan fails: its pose when the error gives one, else the waypoint.
  const n = S.model.axes.length;
  if (Array.isArray(error.pose) && error.pose.length >= Math.min(n, 3)) return error.pose;
  const m = /^waypoints\[(\d+)\]/.exec(error.field || "");
  if (m && body.waypoints[+m[1]]) return body.waypoints[+m[1]];
  if (Array.isArray(error.value) && error.value.length === n && error.value.every(Number.isFinite)) return error.value;
  return null;
}

async function locateSample(error, body) {
  // A speed or acceleration limit depends on the duration only: the same request slowed
  // down F times passes through the same poses, sample k at t·F. Exact unless the planner
  // prepends an approach (its own time law), which shows as a longer plan: then give up.
  if (!["velocity_limit", "acceleration_limit"].includes(error.code) ||
      typeof body.duration !== "number" || typeof error.t !== "number") return null;
  const F = 10;
  try {
    const tr = await api("POST", "/v1/trajectories", { ...body, duration: body.duration * F });
    const n = tr.t.length - 1;
    if (Math.abs(n - Math.round(body.duration * F * tr.rate_hz)) > 1) return null;
    return tr.poses[Math.round(error.t * F * tr.rate_hz)] || null;
  } catch (_) {
    return null;
  }
}

/** A failed plan and where on the canvas it fails (mark null when the error cannot say):
 * the error's own pose or waypoint of `body` (the request refused), else the failing sample
 * located by `locate` (a plan request from the present joints; default `body`). */
export async function failure(error, body, locate = body) {
  return { error, body, mark: markOf(error, body) || await locateSample(error, locate) };
}

export async function preview() {
  if (!readInputs()) { showPlans([], inputsError()); return; }
  const main = $("method").value;
  const methods = [main, ...[...document.querySelectorAll(".overlay-method:checked")]
    .map((e) => e.value).filter((m) => m !== main)];
  const seq = ++S.previewSeq;
  const results = await Promise.all(methods.map(async (m) => {
    const body = planBody(m);
    if (S.state) body.start_joints = S.state.joints;
    try { return [m, { traj: await api("POST", "/v1/trajectories", body), body }]; }
    catch (e) { return [m, await failure(e.error, body)]; }
  }));
  if (seq !== S.previewSeq) return;  // a newer preview was asked for meanwhile
  S.plans = Object.fromEntries(results);
  S.planOrder = methods;
  showPlans(results);
  redraw();
}
