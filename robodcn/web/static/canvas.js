// Coordinates of the arm canvas: the drawing plane (u, v) in metres ↔ canvas pixels, and
// the target frame's handle (its tool axis, turned by dragging).
import { S, $ } from "./state.js";
import { toPlane, view } from "./geometry.js";

export const HANDLE_PX = 46;

export function armView() {
  return view(S.model, $("arm-canvas"));
}

export function toCanvas(u, v) {
  const w = armView();
  return [w.ox + u * w.k, w.oy - v * w.k];
}

export function toWorld(px, py) {
  const w = armView();
  return [(px - w.ox) / w.k, (w.oy - py) / w.k];
}

/** The target in the drawing plane: [u, v, angle]. */
export function targetPlane() {
  return toPlane(S.model, S.target);
}

/** Canvas point of the target frame's handle: HANDLE_PX along its tool axis. */
export function handlePoint() {
  const [u, v, a] = targetPlane();
  const [cx, cy] = toCanvas(u, v);
  return [cx + HANDLE_PX * Math.cos(a), cy - HANDLE_PX * Math.sin(a)];
}

/** Canvas pixels of a pointer event on `canvas` (CSS size may differ from its pixels). */
export function canvasPoint(canvas, ev) {
  const r = canvas.getBoundingClientRect();
  return [(ev.clientX - r.left) * canvas.width / r.width, (ev.clientY - r.top) * canvas.height / r.height];
}
