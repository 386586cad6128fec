// The two time plots under the arm: joint angles (planned dashed, measured solid) and the
// tracking error with, where the state carries it, each joint's |current|.
import { S, $, DEG, JOINT_COLORS } from "./state.js";

function plotAxes(ctx, w, h, t1, lo, hi, unit) {
  ctx.clearRect(0, 0, w, h);
  ctx.strokeStyle = "#dde1e6"; ctx.fillStyle = "#66707c"; ctx.font = "11px system-ui";
  ctx.lineWidth = 1;
  ctx.strokeRect(48, 8, w - 58, h - 30);
  ctx.fillText(`${hi.toFixed(1)}${unit}`, 2, 16); ctx.fillText(`${lo.toFixed(1)}${unit}`, 2, h - 22);
  ctx.fillText("0 s", 48, h - 8); ctx.fillText(`${t1.toFixed(2)} s`, w - 50, h - 8);
  return { x: (t) => 48 + (w - 58) * t / t1, y: (v) => 8 + (h - 30) * (hi - v) / (hi - lo || 1) };
}

function series(ctx, xs, ys, sx, sy, color, dash) {
  ctx.strokeStyle = color; ctx.setLineDash(dash || []); ctx.lineWidth = 1.5;
  ctx.beginPath();
  xs.forEach((t, i) => { i ? ctx.lineTo(sx(t), sy(ys[i])) : ctx.moveTo(sx(t), sy(ys[i])); });
  ctx.stroke(); ctx.setLineDash([]);
}

export function drawPlots() {
  const plan = S.movePlan, meas = S.measured;
  const c1 = $("plot-joints"), x1 = c1.getContext("2d");
  const t1 = Math.max(plan ? plan.t[plan.t.length - 1] : 0, meas.length ? meas[meas.length - 1].t : 0, 0.5);
  const values = [];
  if (plan) plan.joints.forEach((q) => q.forEach((v) => values.push(v / DEG)));
  meas.forEach((m) => m.q.forEach((v) => values.push(v / DEG)));
  const lo = values.length ? Math.min(...values) - 5 : -180, hi = values.length ? Math.max(...values) + 5 : 180;
  const a = plotAxes(x1, c1.width, c1.height, t1, lo, hi, "°");
  for (let j = 0; j < S.dof; j++) {
    const color = JOINT_COLORS[j % JOINT_COLORS.length];
    if (plan) series(x1, plan.t, plan.joints.map((q) => q[j] / DEG), a.x, a.y, color, [5, 4]);
    if (meas.length) series(x1, meas.map((m) => m.t), meas.map((m) => m.q[j] / DEG), a.x, a.y, color);
    x1.fillStyle = color; x1.fillText((S.arm ? S.arm.joint_names[j] : "q" + j), 56 + 70 * j, 22);
  }
  const c2 = $("plot-error"), x2 = c2.getContext("2d");
  const err = meas.filter((m) => m.err !== null && m.err !== undefined);
  const emax = Math.max(0.5, ...err.map((m) => m.err / DEG)) * 1.1;
  const b = plotAxes(x2, c2.width, c2.height, t1, 0, emax, "°");
  if (err.length) series(x2, err.map((m) => m.t), err.map((m) => m.err / DEG), b.x, b.y, "#b3261e");
  const cur = meas.filter((m) => Array.isArray(m.current));
  $("current-caption").hidden = !cur.length;
  if (cur.length) {
    const all = cur.flatMap((m) => m.current.map(Math.abs));
    const cmax = Math.max(1e-9, ...all) * 1.1;
    const sy = (v) => 8 + (c2.height - 30) * (1 - Math.abs(v) / cmax);
    for (let j = 0; j < S.dof; j++) {
      series(x2, cur.map((m) => m.t), cur.map((m) => m.current[j]), b.x, sy,
        JOINT_COLORS[j % JOINT_COLORS.length], [2, 3]);
    }
    x2.fillStyle = "#66707c"; x2.fillText(`|current| max ${cmax.toFixed(2)}`, c2.width - 140, 20);
  }
}
