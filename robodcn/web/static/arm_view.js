// The arm canvas: the drawing plane of the arm (a planar arm seen from above, a yawed arm's
// vertical plane from the side) with its workspace, the planned and measured tool paths,
// the failing sample of an infeasible plan, the arm at its present joints with each joint's
// limits, and the target tool frame.
import { S, $, COLORS, NAMES } from "./state.js";
import { chainPoints, toPlane, yawOf, poseYaw } from "./geometry.js";
import { sideRects, paintRects } from "./zones.js";
import { toCanvas, armView, handlePoint, targetPlane, HANDLE_PX } from "./canvas.js";

function polyline(ctx, pts) {
  ctx.beginPath();
  pts.forEach(([u, v], i) => { const [px, py] = toCanvas(u, v); i ? ctx.lineTo(px, py) : ctx.moveTo(px, py); });
  ctx.stroke();
}

function annulus(ctx, cu, cv, rIn, rOut, k) {
  const [px, py] = toCanvas(cu, cv);
  ctx.beginPath();
  ctx.arc(px, py, rOut * k, 0, 2 * Math.PI);
  if (rIn > 1e-9) { ctx.moveTo(px + rIn * k, py); ctx.arc(px, py, rIn * k, 0, 2 * Math.PI, true); }
}

/** A tool frame at plane pose [u, v, a]: its x axis red along a, its y axis green. */
function drawFrame(ctx, [u, v, a], len, alpha) {
  const [px, py] = toCanvas(u, v);
  const c = Math.cos(a), s = Math.sin(a);
  ctx.globalAlpha = alpha;
  ctx.lineWidth = 2.5;
  ctx.strokeStyle = "#d12b2b";
  ctx.beginPath(); ctx.moveTo(px, py); ctx.lineTo(px + len * c, py - len * s); ctx.stroke();
  ctx.strokeStyle = "#1f9d46";
  ctx.beginPath(); ctx.moveTo(px, py); ctx.lineTo(px - len * s, py - len * c); ctx.stroke();
  ctx.globalAlpha = 1;
}

function drawPath(ctx, poses, color, width, dash) {
  const plane = poses.map((p) => toPlane(S.model, p));
  ctx.strokeStyle = color;
  ctx.lineWidth = width;
  ctx.setLineDash(dash || []);
  polyline(ctx, plane);
  ctx.setLineDash([]);
  // Orientation ticks: the tool's x axis at ~16 samples along the path.
  const step = Math.max(1, Math.floor(plane.length / 16));
  ctx.lineWidth = 1.2;
  for (let i = 0; i < plane.length; i += step) {
    const [px, py] = toCanvas(plane[i][0], plane[i][1]);
    ctx.beginPath(); ctx.moveTo(px, py);
    ctx.lineTo(px + 12 * Math.cos(plane[i][2]), py - 12 * Math.sin(plane[i][2])); ctx.stroke();
  }
}

/** Grid (5 cm), axes, the reachable workspace and, on a full-pose arm, the reach at the
 * target's angle: the tool point lies on the wrist's annulus shifted by the last link. */
function drawWorkspace(ctx, canvas, k) {
  const m = S.model, L = m.lengths, R = m.reach, h = m.height;
  ctx.strokeStyle = "#eef0f3"; ctx.lineWidth = 1;
  if (m.yawed) {
    for (let g = -0.4 * R; g < 1.5 * R; g += 0.05) {
      const c = Math.round(g / 0.05) * 0.05;
      polyline(ctx, [[c, -0.3 * R], [c, h + 1.3 * R]]);
      polyline(ctx, [[-0.4 * R, c], [1.5 * R, c]]);
    }
    ctx.strokeStyle = "#9aa3ad";
    polyline(ctx, [[-0.4 * R, 0], [1.5 * R, 0]]);         // the mounting plate
    ctx.setLineDash([3, 4]); polyline(ctx, [[0, -0.3 * R], [0, h + 1.3 * R]]); ctx.setLineDash([]);
  } else {
    for (let r = 0.05; r < R * 1.12; r += 0.05) { annulus(ctx, 0, 0, 0, r, k); ctx.stroke(); }
    ctx.strokeStyle = "#dde1e6";
    polyline(ctx, [[-R * 1.1, 0], [R * 1.1, 0]]); polyline(ctx, [[0, -R * 1.1], [0, R * 1.1]]);
  }
  // Reachable workspace of the tool point (any angle): Σl outside, max(0, 2·max l − Σl) inside.
  ctx.fillStyle = "rgba(36, 87, 197, 0.06)";
  annulus(ctx, 0, h, Math.max(0, 2 * Math.max(...L) - R), R, k); ctx.fill("evenodd");
  // The keep-out zones over it: only the allowed workspace stays shaded (a yawed arm's
  // boxes cut by the plane the arm or its target is in).
  const yaw = S.target ? poseYaw(m, S.target, 0) : S.state ? yawOf(m, S.state.joints) : 0;
  paintRects(ctx, sideRects(m, yaw, 2 * R + h), toCanvas);
  if (L.length >= 3 && S.target) {
    const w = L.slice(0, -1), ws = w.reduce((a, b) => a + b, 0), last = L[L.length - 1];
    const a = targetPlane()[2];
    ctx.strokeStyle = "rgba(36, 87, 197, 0.45)"; ctx.setLineDash([4, 4]); ctx.lineWidth = 1;
    annulus(ctx, last * Math.cos(a), h + last * Math.sin(a), Math.max(0, 2 * Math.max(...w) - ws), ws, k);
    ctx.stroke(); ctx.setLineDash([]);
  }
  const a = m.angleName;
  ctx.fillStyle = "#66707c"; ctx.font = "11px system-ui";
  // The legend, as much of it as fits the canvas's width.
  const parts = [m.yawed ? "side view (r, z)" : "", "grid 5 cm", `shaded: reach ${R.toFixed(2)} m (any ${a})`,
    m.zones.length ? "red: keep-out zones" : "",
    `dashed ring: reach at the target's ${a}`, "black: measured tool path"].filter(Boolean);
  while (parts.length > 1 && ctx.measureText(parts.join(" · ")).width > canvas.width - 16) parts.pop();
  ctx.fillText(parts.join(" · "), 8, canvas.height - 8);
}

/** The failing sample (or waypoint) of each infeasible plan, in its method's colour; the
 * methods that fail at one spot share one label, kept inside the canvas. */
function drawMarks(ctx) {
  const canvas = ctx.canvas, spots = [];
  S.planOrder.filter((m) => S.plans[m] && S.plans[m].mark).forEach((m) => {
    const p = S.plans[m];
    if (S.model.yawed && p.mark.length < 4) return;
    const [u, v] = toPlane(S.model, p.mark);
    const [px, py] = toCanvas(u, v);
    const where = typeof p.error.sample === "number" ? `sample ${p.error.sample}` : p.error.field || "";
    const spot = spots.find((s) => Math.hypot(s.px - px, s.py - py) < 4 && s.where === where);
    if (spot) spot.methods.push(m); else spots.push({ px, py, where, methods: [m] });
  });
  spots.forEach((spot, k) => {
    const { px, py } = spot;
    ctx.strokeStyle = "#b3261e"; ctx.lineWidth = 3;
    ctx.beginPath(); ctx.moveTo(px - 8, py - 8); ctx.lineTo(px + 8, py + 8);
    ctx.moveTo(px + 8, py - 8); ctx.lineTo(px - 8, py + 8); ctx.stroke();
    spot.methods.forEach((m, i) => {
      ctx.strokeStyle = COLORS[m] || "#b3261e"; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.arc(px, py, 12 + 3 * i, 0, 2 * Math.PI); ctx.stroke();
    });
    ctx.fillStyle = COLORS[spot.methods[0]] || "#b3261e"; ctx.font = "12px system-ui";
    const text = `${spot.methods.map((m) => NAMES[m]).join(", ")}: ${spot.where}`;
    const w = ctx.measureText(text).width;
    // right of the mark, or left of it where the right runs off the canvas
    let x = px + 18 + 3 * spot.methods.length;
    if (x + w > canvas.width - 4) x = Math.max(4, px - 18 - 3 * spot.methods.length - w);
    const y = Math.min(canvas.height - 24, Math.max(14, py - 10 + 14 * k));
    ctx.fillText(text, x, y);
    spot.label = { x, y, w };
  });
  S.markLabels = spots.map((s) => ({ methods: s.methods, ...s.label }));
}

/** The arm at joints q: each chain joint's allowed range (relative to the previous link),
 * the links, the joints and the base; the present tool frame. */
function drawArmAt(ctx, q) {
  const m = S.model, { pts, dir } = chainPoints(m, q), first = m.yawed ? 1 : 0;
  for (let i = 0; i < m.lengths.length && i + first < S.limits.length; i++) {
    const [px, py] = toCanvas(pts[i][0], pts[i][1]);
    const lim = S.limits[i + first], a0 = dir(i, lim[0]), a1 = dir(i, lim[1]);
    // canvas y is down: angles are negated, the arc runs from −max to −min
    ctx.fillStyle = "rgba(31, 122, 58, 0.10)";
    ctx.beginPath(); ctx.moveTo(px, py);
    ctx.arc(px, py, 26, -Math.max(a0, a1), -Math.min(a0, a1)); ctx.closePath(); ctx.fill();
    ctx.strokeStyle = "#b3261e"; ctx.lineWidth = 1.5;
    for (const a of [a0, a1]) {
      ctx.beginPath(); ctx.moveTo(px, py);
      ctx.lineTo(px + 28 * Math.cos(a), py - 28 * Math.sin(a)); ctx.stroke();
    }
  }
  ctx.strokeStyle = "#38404a"; ctx.lineWidth = 7; ctx.lineCap = "round";
  polyline(ctx, m.yawed ? [[0, 0], ...pts] : pts);      // a yawed arm's column to the shoulder
  ctx.lineCap = "butt";
  for (const [u, v] of pts.slice(0, -1)) {
    const [px, py] = toCanvas(u, v);
    ctx.fillStyle = "#fff"; ctx.strokeStyle = "#38404a"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.arc(px, py, 5, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
  }
  const [bx, by] = toCanvas(0, 0);
  ctx.fillStyle = "#38404a"; ctx.fillRect(bx - 10, by - (m.yawed ? 6 : 10), 20, m.yawed ? 12 : 20);
  drawFrame(ctx, toPlane(m, S.state.pose), 30, 1);
}

/** The target tool frame: drag the ring to move it, the handle to turn it. */
function drawTarget(ctx) {
  const plane = targetPlane();
  drawFrame(ctx, plane, HANDLE_PX, 0.55);
  const [tx, ty] = toCanvas(plane[0], plane[1]);
  const [hx, hy] = handlePoint();
  ctx.strokeStyle = "#d12b2b"; ctx.lineWidth = 2;
  ctx.beginPath(); ctx.arc(tx, ty, 9, 0, 2 * Math.PI); ctx.stroke();
  ctx.fillStyle = "#d12b2b";
  ctx.beginPath(); ctx.arc(hx, hy, 6, 0, 2 * Math.PI); ctx.fill();
}

export function drawArm() {
  const canvas = $("arm-canvas"), ctx = canvas.getContext("2d");
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (!S.model || !S.model.lengths.length) return;
  drawWorkspace(ctx, canvas, armView().k);
  // Planned paths: the preview's methods (the chosen one on top), then the move's plan.
  const main = $("method").value;
  for (const m of [...S.planOrder.filter((n) => n !== main), main]) {
    const p = S.plans[m];
    if (p && p.traj) drawPath(ctx, p.traj.poses, COLORS[m] || "#555", m === main ? 2.5 : 1.5);
  }
  if (S.movePlan) drawPath(ctx, S.movePlan.poses, "#444", 1.2, [6, 4]);
  drawMarks(ctx);
  if (S.measured.length > 1) {
    ctx.strokeStyle = "#111"; ctx.lineWidth = 2;
    polyline(ctx, S.measured.map((m) => toPlane(S.model, m.pose)));
  }
  if (S.state) drawArmAt(ctx, S.state.joints);
  if (S.target) drawTarget(ctx);
}
