// Pointer, wheel and keyboard on the arm's drawings: drag the target frame's ring to move
// it, its handle (or the mouse wheel) to turn it; a click elsewhere puts the target there;
// on a yawed arm's top view a click or drag turns its yaw. Where the service offers follow
// sessions and no move runs, a drag moves the arm live (follow.js); else the drop previews.
// Keys jog (Escape stops).
import { S, $, DEG } from "./state.js";
import { fromPlane, poseYaw } from "./geometry.js";
import { canvasPoint, handlePoint, targetPlane, toCanvas, toWorld } from "./canvas.js";
import { topToWorld } from "./top_view.js";
import { schedulePreview, setTarget } from "./plan.js";
import { redraw } from "./draw.js";
import { jog, stop } from "./control.js";
import { followEnd, followStart, followTarget } from "./follow.js";

/** The target moved to plane point (u, v) or turned to angle a, at the target's yaw. */
function setPlane(u, v, a) {
  const yaw = poseYaw(S.model, S.target, S.state ? S.state.joints[0] : 0);
  setTarget(fromPlane(S.model, [u, v, a], yaw));
}

/** The end of a drag: the arm rests at a followed target (the plans drawn before the drag
 * are stale: dropped), else the drop previews. */
function dropped() {
  S.drag = null;
  if (followEnd()) { S.plans = {}; S.planOrder = []; redraw(); } else schedulePreview();
}

function bindArmCanvas() {
  const c = $("arm-canvas");
  c.addEventListener("pointerdown", (ev) => {
    if (!S.target) return;
    const [px, py] = canvasPoint(c, ev);
    const [hx, hy] = handlePoint();
    const [u, v, a] = targetPlane();
    const [tx, ty] = toCanvas(u, v);
    if (Math.hypot(px - hx, py - hy) < 11) S.drag = "turn";
    else {
      S.drag = "move";
      if (Math.hypot(px - tx, py - ty) > 14) {  // a click elsewhere puts the target there
        const [wu, wv] = toWorld(px, py);
        setPlane(wu, wv, a);
      }
      const [nx, ny] = toCanvas(...targetPlane().slice(0, 2));
      S.dragOffset = [px - nx, py - ny];
    }
    followStart();
    c.setPointerCapture(ev.pointerId);
    ev.preventDefault();
  });
  c.addEventListener("pointermove", (ev) => {
    if (!S.drag || S.drag === "yaw") return;
    const [px, py] = canvasPoint(c, ev);
    const [u, v, a] = targetPlane();
    if (S.drag === "turn") {
      const [tx, ty] = toCanvas(u, v);
      setPlane(u, v, Math.atan2(-(py - ty), px - tx));
    } else {
      const [wu, wv] = toWorld(px - S.dragOffset[0], py - S.dragOffset[1]);
      setPlane(wu, wv, a);
    }
    followTarget(S.target);
  });
  const end = () => { if (S.drag && S.drag !== "yaw") dropped(); };
  c.addEventListener("pointerup", end);
  c.addEventListener("pointercancel", end);
  c.addEventListener("wheel", (ev) => {
    if (!S.target) return;
    ev.preventDefault();
    const [u, v, a] = targetPlane();
    setPlane(u, v, a + Math.sign(-ev.deltaY) * 5 * DEG);
    schedulePreview();
  }, { passive: false });
}

function bindTopView() {
  const c = $("arm-top");
  const turn = (ev) => {
    const [x, y] = topToWorld(...canvasPoint(c, ev));
    if (Math.hypot(x, y) < 1e-3) return;
    const [u, v, a] = targetPlane();
    setTarget(fromPlane(S.model, [u, v, a], Math.atan2(y, x)));
  };
  c.addEventListener("pointerdown", (ev) => {
    if (!S.target || !S.model.yawed) return;
    S.drag = "yaw";
    turn(ev);
    followStart();
    c.setPointerCapture(ev.pointerId);
    ev.preventDefault();
  });
  c.addEventListener("pointermove", (ev) => {
    if (S.drag === "yaw") { turn(ev); followTarget(S.target); }
  });
  const end = () => { if (S.drag === "yaw") dropped(); };
  c.addEventListener("pointerup", end);
  c.addEventListener("pointercancel", end);
}

export function bindCanvas() {
  bindArmCanvas();
  bindTopView();
}

export function bindKeys() {
  const keys = { ArrowLeft: "-x", ArrowRight: "+x", ArrowUp: "+y", ArrowDown: "-y", q: "+t", e: "-t",
    PageUp: "+z", PageDown: "-z" };
  document.addEventListener("keydown", (ev) => {
    const tag = (ev.target && ev.target.tagName) || "";
    if (["INPUT", "SELECT", "TEXTAREA"].includes(tag) || ev.ctrlKey || ev.metaKey || ev.altKey) return;
    if (ev.key === "Escape") { stop("smooth"); ev.preventDefault(); return; }
    const dir = keys[ev.key] || keys[ev.key.toLowerCase()];
    if (!dir || !S.hasArm || (dir.endsWith("z") && !S.model.yawed)) return;
    jog(dir);
    ev.preventDefault();
  });
}
