// One redraw per animation frame, however many events asked for it.
import { drawArm } from "./arm_view.js";
import { drawTop } from "./top_view.js";
import { drawPlots } from "./plots.js";

let pending = false;

export function drawNow() {
  drawArm();
  drawTop();
  drawPlots();
}

export function redraw() {
  if (pending) return;
  pending = true;
  requestAnimationFrame(() => { pending = false; drawNow(); });
}
