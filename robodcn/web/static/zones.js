// The arm's keep-out zones (GET /v1/arm keep_out; [workspace] of its file) on the canvases:
// painted over the reachable shading, so only the allowed workspace stays shaded. A plan
// whose arm enters one is refused (422 keep_out).
//   side view (r, z) of a yawed arm: the floor below its height, the base cylinder as the
//     band |r| < radius up to its top, each box's section by the arm's plane at `yaw`;
//   a planar arm's plane (x, y): a vertical arm's floor, each box's rectangle;
//   top view (x, y) of a yawed arm: the base cylinder's disc and each box's rectangle.

const FILL = "rgba(179, 38, 30, 0.10)", EDGE = "rgba(179, 38, 30, 0.55)";

/** The r-interval (or null) where the vertical plane at `yaw` crosses box [lo, hi] in
 * (x, y): (r cos yaw, r sin yaw) inside the rectangle, by the slab method. */
export function boxSection(lo, hi, yaw) {
  const d = [Math.cos(yaw), Math.sin(yaw)];
  let a = -Infinity, b = Infinity;
  for (let i = 0; i < 2; i++) {
    if (Math.abs(d[i]) < 1e-12) {
      if (!(lo[i] < 0 && 0 < hi[i])) return null;
      continue;
    }
    const t0 = lo[i] / d[i], t1 = hi[i] / d[i];
    a = Math.max(a, Math.min(t0, t1)); b = Math.min(b, Math.max(t0, t1));
  }
  return a < b ? [a, b] : null;
}

/** Rectangles [u0, v0, u1, v1] of the zones in the drawing plane (module comment). */
export function sideRects(model, yaw, span) {
  const out = [];
  for (const z of model.zones || []) {
    if (z.kind === "floor") out.push([-span, z.height - span, span, z.height]);
    else if (z.kind === "cylinder") out.push([-z.radius, -span, z.radius, z.top]);
    else if (z.kind === "box" && !model.yawed) out.push([z.min[0], z.min[1], z.max[0], z.max[1]]);
    else if (z.kind === "box") {
      const s = boxSection(z.min, z.max, yaw);
      if (s) out.push([s[0], z.min[2], s[1], z.max[2]]);
    }
  }
  return out;
}

/** Paint rectangles given in world coordinates through `toPx` (world → canvas pixels):
 * white over the shading and grid, then the zone's red. */
export function paintRects(ctx, rects, toPx) {
  for (const [u0, v0, u1, v1] of rects) {
    const [ax, ay] = toPx(u0, v1), [bx, by] = toPx(u1, v0);
    const x = Math.min(ax, bx), y = Math.min(ay, by), w = Math.abs(bx - ax), h = Math.abs(by - ay);
    ctx.fillStyle = "#fff"; ctx.fillRect(x, y, w, h);
    ctx.fillStyle = FILL; ctx.fillRect(x, y, w, h);
    ctx.strokeStyle = EDGE; ctx.lineWidth = 1; ctx.setLineDash([4, 3]);
    ctx.strokeRect(x, y, w, h); ctx.setLineDash([]);
  }
}

/** The top view: the base cylinder's disc and the boxes' rectangles. */
export function paintTop(ctx, model, toPx, k) {
  for (const z of model.zones || []) {
    if (z.kind === "cylinder") {
      const [cx, cy] = toPx(0, 0);
      ctx.fillStyle = "#fff"; ctx.beginPath(); ctx.arc(cx, cy, z.radius * k, 0, 2 * Math.PI); ctx.fill();
      ctx.fillStyle = FILL; ctx.fill();
      ctx.strokeStyle = EDGE; ctx.lineWidth = 1; ctx.stroke();
    } else if (z.kind === "box") {
      paintRects(ctx, [[z.min[0], z.min[1], z.max[0], z.max[1]]], toPx);
    }
  }
}
