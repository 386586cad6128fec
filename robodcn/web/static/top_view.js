// The top view (x, y) of a yawed arm: the yaw axis at the centre, the yaw's limits, the
// arm's links projected onto the floor at its yaw, the tool paths and the target. Shown
// only for a yawed arm (beside the side view of its vertical plane).
import { S, $, COLORS } from "./state.js";
import { chainPoints, topView, yawOf } from "./geometry.js";
import { paintTop } from "./zones.js";

/** Canvas pixels of base-frame (x, y) on the top view. */
export function topToCanvas(x, y) {
  const v = topView(S.model, $("arm-top"));
  return [v.ox + x * v.k, v.oy - y * v.k];
}

/** Base-frame (x, y) of top-view pixels. */
export function topToWorld(px, py) {
  const v = topView(S.model, $("arm-top"));
  return [(px - v.ox) / v.k, (v.oy - py) / v.k];
}

function line(ctx, pts) {
  ctx.beginPath();
  pts.forEach(([x, y], i) => { const [px, py] = topToCanvas(x, y); i ? ctx.lineTo(px, py) : ctx.moveTo(px, py); });
  ctx.stroke();
}

export function drawTop() {
  const canvas = $("arm-top");
  canvas.hidden = !(S.model && S.model.yawed);
  if (canvas.hidden) return;
  const ctx = canvas.getContext("2d"), m = S.model, R = m.reach;
  const { k, ox, oy } = topView(m, canvas);
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  ctx.strokeStyle = "#eef0f3"; ctx.lineWidth = 1;
  for (let r = 0.05; r < R * 1.12; r += 0.05) { ctx.beginPath(); ctx.arc(ox, oy, r * k, 0, 2 * Math.PI); ctx.stroke(); }
  ctx.strokeStyle = "#dde1e6";
  line(ctx, [[-R * 1.1, 0], [R * 1.1, 0]]); line(ctx, [[0, -R * 1.1], [0, R * 1.1]]);
  ctx.fillStyle = "rgba(36, 87, 197, 0.06)";
  ctx.beginPath(); ctx.arc(ox, oy, R * k, 0, 2 * Math.PI); ctx.fill();
  paintTop(ctx, m, topToCanvas, k);
  if (S.limits.length) {               // the yaw's allowed range
    const [lo, hi] = S.limits[0];
    ctx.fillStyle = "rgba(31, 122, 58, 0.10)";
    ctx.beginPath(); ctx.moveTo(ox, oy); ctx.arc(ox, oy, 30, -hi, -lo); ctx.closePath(); ctx.fill();
  }
  const main = $("method").value;
  for (const name of S.planOrder) {
    const p = S.plans[name];
    if (!p || !p.traj) continue;
    ctx.strokeStyle = COLORS[name] || "#555"; ctx.lineWidth = name === main ? 2.5 : 1.5;
    line(ctx, p.traj.poses.map((q) => [q[0], q[1]]));
  }
  if (S.movePlan) {
    ctx.strokeStyle = "#444"; ctx.lineWidth = 1.2; ctx.setLineDash([6, 4]);
    line(ctx, S.movePlan.poses.map((q) => [q[0], q[1]])); ctx.setLineDash([]);
  }
  if (S.measured.length > 1) {
    ctx.strokeStyle = "#111"; ctx.lineWidth = 2;
    line(ctx, S.measured.map((s) => [s.pose[0], s.pose[1]]));
  }
  if (S.state) {
    const yaw = yawOf(m, S.state.joints), c = Math.cos(yaw), s = Math.sin(yaw);
    const pts = chainPoints(m, S.state.joints).pts.map(([u]) => [u * c, u * s]);
    ctx.strokeStyle = "#38404a"; ctx.lineWidth = 7; ctx.lineCap = "round";
    line(ctx, [[0, 0], ...pts]); ctx.lineCap = "butt";
    ctx.fillStyle = "#38404a"; ctx.beginPath(); ctx.arc(ox, oy, 9, 0, 2 * Math.PI); ctx.fill();
  }
  if (S.target) {
    const [tx, ty] = topToCanvas(S.target[0], S.target[1]);
    ctx.strokeStyle = "#d12b2b"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.arc(tx, ty, 9, 0, 2 * Math.PI); ctx.stroke();
  }
  ctx.fillStyle = "#66707c"; ctx.font = "11px system-ui";
  ctx.fillText("top view (x, y): click or drag to turn the yaw", 8, canvas.height - 8);
}
