// robodcn web console: vanilla JS ES modules, no dependencies, no build step. Talks to the
// service it is served by: GET /openapi.json (what it offers, and the ranges of its body
// fields), GET /v1/arm, GET /v1/events (SSE), POST /v1/trajectories (preview), POST
// /v1/moves, GET /v1/moves/{id}/trajectory (the plan a move runs), POST /v1/stop, and
// pause/resume/speed/torque/gripper and follow sessions (POST /v1/follow, PUT
// /v1/follow/target, DELETE /v1/follow: a drag of the target) where the OpenAPI document
// lists them. SI units on the
// wire; degrees and millimetres in the UI.
//
// Modules: state (S), api (requests, OpenAPI features), geometry (the arm model), canvas,
// arm_view, top_view, plots, draw (drawings), plan, plan_table (the plan form), status
// (readouts, the move), control (buttons), follow (a drag moves the arm live), events
// (SSE), input (pointer and keys).
import { S, $ } from "./state.js";
import { api, detectFeatures } from "./api.js";
import { clearError, setLink, showError, showTokenBox } from "./ui.js";
import { loadArm } from "./geometry.js";
import { toCanvas } from "./canvas.js";
import { topToCanvas } from "./top_view.js";
import { drawNow, redraw } from "./draw.js";
import { preview, readInputs, schedulePreview, setTarget } from "./plan.js";
import { moveReason, onState, updateButtons } from "./status.js";
import { gripper, jog, post, setSpeed, startMove, stop, torque } from "./control.js";
import { connect } from "./events.js";
import { bindCanvas, bindKeys } from "./input.js";

function bindControls() {
  $("preview").addEventListener("click", preview);
  $("move").addEventListener("click", startMove);
  $("stop").addEventListener("click", () => stop("smooth"));
  $("hold").addEventListener("click", () => stop("hold"));
  $("pause").addEventListener("click", () => post("/v1/pause", {}));
  $("resume").addEventListener("click", () => post("/v1/resume", {}));
  $("speed").addEventListener("input", () => {
    S.speedEditing = true;
    $("speed-value").textContent = `${Math.round(100 * parseFloat($("speed").value))} %`;
  });
  $("speed").addEventListener("change", () => setSpeed(parseFloat($("speed").value)));
  $("torque-on").addEventListener("click", () => torque(true));
  $("torque-off").addEventListener("click", () => torque(false));
  document.querySelectorAll("[data-gripper]").forEach((b) =>
    b.addEventListener("click", () => gripper(b.dataset.gripper)));
  document.querySelectorAll("[data-jog]").forEach((b) => b.addEventListener("click", () => jog(b.dataset.jog)));
  document.querySelectorAll(".target-axis input").forEach((box) =>
    box.addEventListener("input", () => { if (readInputs()) schedulePreview(); }));
  $("method").addEventListener("change", schedulePreview);
  $("duration").addEventListener("change", schedulePreview);
  $("tool-speed").addEventListener("change", schedulePreview);
  document.querySelectorAll(".overlay-method").forEach((b) => b.addEventListener("change", schedulePreview));
  $("beta").addEventListener("input", () => {
    $("beta-value").textContent = parseFloat($("beta").value).toFixed(2);
    schedulePreview();
  });
  $("token").value = S.token;
  $("token-box").addEventListener("submit", (ev) => { ev.preventDefault(); $("token").blur(); });
  $("token").addEventListener("change", () => {
    S.token = $("token").value.trim();
    if (S.token) sessionStorage.setItem("robodcn-token", S.token);
    else sessionStorage.removeItem("robodcn-token");
    clearError();
  });
}

/** Sliders and inputs from the contract: β's range, the speed scale's, the gripper's. */
function applyRanges() {
  const f = S.features;
  if (f.betaRange) {
    const [lo, hi] = f.betaRange, beta = $("beta");
    const value = Math.min(hi, Math.max(lo, parseFloat(beta.value)));
    beta.min = lo; beta.max = hi; beta.value = value;
    $("beta-value").textContent = parseFloat(beta.value).toFixed(2);
  }
  $("speed").min = f.speedRange[0]; $("speed").max = f.speedRange[1];
  $("tool-speed-box").hidden = !f.toolSpeed;
  if (f.toolSpeedMax !== null && parseFloat($("tool-speed").value) > 1000 * f.toolSpeedMax) {
    $("tool-speed").value = String(1000 * f.toolSpeedMax);  // the arm's own ceiling is lower
  }
  if (f.gripper) {
    document.querySelectorAll("[data-gripper]").forEach((b) => {
      const cmd = b.dataset.gripper;
      b.hidden = cmd === "width" ? !f.gripper.width : !f.gripper.commands.includes(cmd);
    });
    $("gripper-width-box").hidden = !f.gripper.width;
    if (f.gripper.widthRange) {
      $("gripper-width").min = 1000 * f.gripper.widthRange[0];
      $("gripper-width").max = 1000 * f.gripper.widthRange[1];
    }
  }
}

/** The pose inputs and jog buttons of the arm's axes (x, y, θ or x, y, z, pitch). */
function applyModel() {
  const axes = S.model.axes;
  document.querySelectorAll(".target-axis").forEach((label) => {
    label.hidden = !axes.includes(label.dataset.axis);
  });
  document.querySelectorAll("[data-jog$='z']").forEach((b) => { b.hidden = !S.model.yawed; });
  document.querySelectorAll(".angle-name").forEach((e) => { e.textContent = S.model.angleName; });
}

async function init() {
  bindControls();
  bindCanvas();
  bindKeys();
  try {
    [S.api, S.arm] = await Promise.all([api("GET", "/openapi.json"), api("GET", "/v1/arm")]);
  } catch (e) {
    showError(e.error);
    return;
  }
  detectFeatures();
  if (S.tokenRequired) showTokenBox();
  S.model = loadArm(S.arm);
  S.dof = S.arm.dof;
  S.limits = S.arm.config.joints.map((j) => [j.min, j.max]);
  S.home = S.model.home.slice();
  $("arm-name").textContent = S.arm.name;
  applyModel();
  applyRanges();
  // A plan-only server has no arm attached: no events, no moves.
  try {
    onState(await api("GET", "/v1/state"));
  } catch (e) {
    if (e.error && e.error.code === "no_arm") {
      S.hasArm = false;
      setLink("plan only", false);
      setTarget(S.home.slice());
    }
  }
  updateButtons();
  if (S.hasArm) connect();
  redraw();
}

// For tests and the curious: the page's state and a synchronous redraw.
window.robodcnConsole = { S, toCanvas, topToCanvas, preview, draw: drawNow, stats: S.stats, moveReason };
if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", init);
else init();
