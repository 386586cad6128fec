// robodcn web console: vanilla JS, no dependencies. Talks to the service it is served by:
// GET /openapi.json (feature detection), GET /v1/arm, GET /v1/events (SSE), POST
// /v1/trajectories (preview), POST /v1/moves, POST /v1/stop, and pause/resume/speed/torque
// where the OpenAPI document lists them. SI units on the wire; degrees in the UI.
"use strict";

const DEG = Math.PI / 180;
const COLORS = { sclerp: "#2457c5", kenlerp: "#c2410c", seplerp: "#15803d", dlb: "#7e22ce" };
const NAMES = { sclerp: "ScLERP", kenlerp: "KenLERP", seplerp: "SEP-LERP", dlb: "DLB" };
const JOINT_COLORS = ["#2457c5", "#c2410c", "#15803d", "#7e22ce", "#0e7490", "#a16207"];
const ACTIVE = ["queued", "running"];

const S = {
  api: null, arm: null, links: [], limits: [], dof: 0, home: [0, 0, 0],
  token: sessionStorage.getItem("robodcn-token") || "", tokenRequired: false,
  features: {}, hasArm: true, state: null, move: null, target: null,
  plans: {}, planOrder: [], previewBody: null, movePlan: null, measured: [],
  trackedMove: null, es: null, backoff: 1000, drag: null,
  stats: { state: 0, move: 0, alert: 0, stamps: [] },
};
const $ = (id) => document.getElementById(id);

// -- the service ------------------------------------------------------------------------------

async function api(method, path, body) {
  if (method !== "GET" && S.tokenRequired && !S.token) {
    showTokenBox();
    throw { status: 401, error: { code: "unauthorized", field: "token",
      message: "this server needs a token: enter it in the token field (top right)" } };
  }
  const headers = {};
  if (body !== undefined) headers["Content-Type"] = "application/json";
  if (method !== "GET" && S.token) headers.Authorization = "Bearer " + S.token;
  const r = await fetch(path, { method, headers,
    body: body === undefined ? undefined : JSON.stringify(body) });
  let data = null;
  try { data = await r.json(); } catch (_) { data = null; }
  if (!r.ok) {
    if (r.status === 401) showTokenBox();
    throw { status: r.status, error: (data && data.error) ||
      { code: "http_" + r.status, message: `${r.status} ${r.statusText}`, field: null } };
  }
  return data;
}

function op(path, method) {
  const p = S.api && S.api.paths && S.api.paths[path];
  return (p && p[method]) || null;
}

function bodyProps(path, method) {
  const o = op(path, method);
  const content = o && o.requestBody && o.requestBody.content;
  let schema = content && content["application/json"] && content["application/json"].schema;
  if (schema && schema.$ref) schema = S.api.components.schemas[schema.$ref.split("/").pop()];
  // A body of several forms (anyOf/oneOf, e.g. waypoints or a given trajectory): any form's
  // fields count.
  const forms = schema && !schema.properties && (schema.anyOf || schema.oneOf);
  if (forms) {
    return Object.assign({}, ...forms.map((f) =>
      ((f.$ref ? S.api.components.schemas[f.$ref.split("/").pop()] : f) || {}).properties || {}));
  }
  return (schema && schema.properties) || {};
}

function pick(options, wanted) {
  return wanted.find((w) => options.includes(w)) || null;
}

function detectFeatures() {
  const f = {};
  const stop = bodyProps("/v1/stop", "post");
  const modes = (stop.mode && (stop.mode.enum || (stop.mode.oneOf || []).flatMap((s) => s.enum || [])))
    || [];
  f.smoothStop = pick(modes, ["smooth", "decelerate", "ramp", "soft"]);
  f.holdStop = pick(modes, ["hold", "immediate", "now", "hard"]);
  f.replace = "replace" in bodyProps("/v1/moves", "post");
  f.pause = !!op("/v1/pause", "post");
  f.resume = !!op("/v1/resume", "post");
  const speed = bodyProps("/v1/speed", "put");
  f.speed = op("/v1/speed", "put") ? (Object.keys(speed).find((k) =>
    ["number", "integer"].includes(speed[k].type)) || "speed") : null;
  const sp = f.speed && speed[f.speed];
  // an exclusive minimum (0 < k) is not a value to send: the slider starts one step above it
  f.speedRange = sp ? [sp.minimum ?? (sp.exclusiveMinimum !== undefined ? sp.exclusiveMinimum + 0.05 : 0.05),
    sp.maximum ?? 1] : [0.05, 1];
  const torque = bodyProps("/v1/torque", "post");
  f.torque = op("/v1/torque", "post") ? (Object.keys(torque).find((k) =>
    torque[k].type === "boolean") || "enabled") : null;
  S.features = f;
  S.tokenRequired = !!(S.api.components && S.api.components.securitySchemes &&
    S.api.components.securitySchemes.bearer);
}

// -- geometry -----------------------------------------------------------------------------------

function fkPoints(q) {
  // Joint positions from the base to the tool point: (Σ l cos φ, Σ l sin φ), φ = cumsum q.
  const pts = [[0, 0]];
  let phi = 0, x = 0, y = 0;
  for (let i = 0; i < S.links.length; i++) {
    phi += q[i] || 0;
    x += S.links[i] * Math.cos(phi);
    y += S.links[i] * Math.sin(phi);
    pts.push([x, y]);
  }
  return { pts, phi };
}

function view(canvas) {
  const reach = S.links.reduce((a, b) => a + b, 0) || 0.5;
  const k = Math.min(canvas.width, canvas.height) / (2 * reach * 1.12);
  return { k, ox: canvas.width / 2, oy: canvas.height / 2 };
}
function toCanvas(x, y) {
  const v = view($("arm-canvas"));
  return [v.ox + x * v.k, v.oy - y * v.k];
}
function toWorld(px, py) {
  const v = view($("arm-canvas"));
  return [(px - v.ox) / v.k, (v.oy - py) / v.k];
}
const HANDLE_PX = 46;
function handlePoint() {
  const [cx, cy] = toCanvas(S.target[0], S.target[1]);
  return [cx + HANDLE_PX * Math.cos(S.target[2]), cy - HANDLE_PX * Math.sin(S.target[2])];
}
function presentPose() {
  return S.state ? S.state.pose.slice() : S.home.slice();
}

// -- drawing ------------------------------------------------------------------------------------

let drawPending = false;
function redraw() {
  if (drawPending) return;
  drawPending = true;
  requestAnimationFrame(() => { drawPending = false; drawArm(); drawPlots(); });
}

function polyline(ctx, pts) {
  ctx.beginPath();
  pts.forEach(([x, y], i) => { const [px, py] = toCanvas(x, y); i ? ctx.lineTo(px, py) : ctx.moveTo(px, py); });
  ctx.stroke();
}

function annulus(ctx, cx, cy, rIn, rOut, k) {
  const [px, py] = toCanvas(cx, cy);
  ctx.beginPath();
  ctx.arc(px, py, rOut * k, 0, 2 * Math.PI);
  if (rIn > 1e-9) { ctx.moveTo(px + rIn * k, py); ctx.arc(px, py, rIn * k, 0, 2 * Math.PI, true); }
}

function drawFrame(ctx, pose, len, alpha) {
  const [px, py] = toCanvas(pose[0], pose[1]);
  const c = Math.cos(pose[2]), s = Math.sin(pose[2]);
  ctx.globalAlpha = alpha;
  ctx.lineWidth = 2.5;
  ctx.strokeStyle = "#d12b2b";
  ctx.beginPath(); ctx.moveTo(px, py); ctx.lineTo(px + len * c, py - len * s); ctx.stroke();
  ctx.strokeStyle = "#1f9d46";
  ctx.beginPath(); ctx.moveTo(px, py); ctx.lineTo(px - len * s, py - len * c); ctx.stroke();
  ctx.globalAlpha = 1;
}

function drawPath(ctx, poses, color, width, dash) {
  ctx.strokeStyle = color;
  ctx.lineWidth = width;
  ctx.setLineDash(dash || []);
  polyline(ctx, poses.map((p) => [p[0], p[1]]));
  ctx.setLineDash([]);
  // Orientation ticks: the tool's x axis at ~16 samples along the path.
  const step = Math.max(1, Math.floor(poses.length / 16));
  ctx.lineWidth = 1.2;
  for (let i = 0; i < poses.length; i += step) {
    const [px, py] = toCanvas(poses[i][0], poses[i][1]);
    ctx.beginPath(); ctx.moveTo(px, py);
    ctx.lineTo(px + 12 * Math.cos(poses[i][2]), py - 12 * Math.sin(poses[i][2])); ctx.stroke();
  }
}

function drawArm() {
  const canvas = $("arm-canvas"), ctx = canvas.getContext("2d");
  const { k } = view(canvas);
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (!S.links.length) return;
  const sum = S.links.reduce((a, b) => a + b, 0), longest = Math.max(...S.links);
  // Grid: 5 cm rings, axes.
  ctx.strokeStyle = "#eef0f3"; ctx.lineWidth = 1;
  for (let r = 0.05; r < sum * 1.12; r += 0.05) { annulus(ctx, 0, 0, 0, r, k); ctx.stroke(); }
  ctx.strokeStyle = "#dde1e6";
  polyline(ctx, [[-sum * 1.1, 0], [sum * 1.1, 0]]); polyline(ctx, [[0, -sum * 1.1], [0, sum * 1.1]]);
  // Reachable workspace of the tool point (any θ): Σl outside, max(0, 2·max l − Σl) inside.
  ctx.fillStyle = "rgba(36, 87, 197, 0.06)";
  annulus(ctx, 0, 0, Math.max(0, 2 * longest - sum), sum, k); ctx.fill("evenodd");
  if (S.dof >= 3 && S.target) {
    // At the target's θ the tool point lies on the wrist's annulus shifted by l3 along θ.
    const w = S.links.slice(0, -1), ws = w.reduce((a, b) => a + b, 0), wl = Math.max(...w);
    const l3 = S.links[S.links.length - 1];
    ctx.strokeStyle = "rgba(36, 87, 197, 0.45)"; ctx.setLineDash([4, 4]); ctx.lineWidth = 1;
    annulus(ctx, l3 * Math.cos(S.target[2]), l3 * Math.sin(S.target[2]),
      Math.max(0, 2 * wl - ws), ws, k);
    ctx.stroke(); ctx.setLineDash([]);
  }
  ctx.fillStyle = "#66707c"; ctx.font = "11px system-ui";
  ctx.fillText(`grid 5 cm · shaded: reach ${sum.toFixed(2)} m (any θ) · dashed ring: reach at ` +
    "the target's θ · black: measured tool path", 8, canvas.height - 8);

  // Planned paths: the preview's methods, then the running move's plan.
  const main = $("method").value;
  for (const m of [...S.planOrder.filter((n) => n !== main), main]) {  // the chosen one on top
    const p = S.plans[m];
    if (p && p.traj) drawPath(ctx, p.traj.poses, COLORS[m] || "#555", m === main ? 2.5 : 1.5);
  }
  if (S.movePlan) drawPath(ctx, S.movePlan.poses, "#444", 1.2, [6, 4]);
  // The failing sample (or waypoint) of an infeasible plan, in its method's colour.
  S.planOrder.filter((m) => S.plans[m] && S.plans[m].mark).forEach((m, i) => {
    const p = S.plans[m];
    const [px, py] = toCanvas(p.mark[0], p.mark[1]);
    ctx.strokeStyle = "#b3261e"; ctx.lineWidth = 3;
    ctx.beginPath(); ctx.moveTo(px - 8, py - 8); ctx.lineTo(px + 8, py + 8);
    ctx.moveTo(px + 8, py - 8); ctx.lineTo(px - 8, py + 8); ctx.stroke();
    ctx.strokeStyle = COLORS[m] || "#b3261e"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.arc(px, py, 12 + 3 * i, 0, 2 * Math.PI); ctx.stroke();
    ctx.fillStyle = COLORS[m] || "#b3261e"; ctx.font = "12px system-ui";
    const where = typeof p.error.sample === "number" ? `sample ${p.error.sample}` : p.error.field || "";
    ctx.fillText(`${NAMES[m]}: ${where}`, px + 18, py - 10 + 14 * i);
  });
  // Measured tool path of the latest move.
  if (S.measured.length > 1) {
    ctx.strokeStyle = "#111"; ctx.lineWidth = 2;
    polyline(ctx, S.measured.map((m) => [m.pose[0], m.pose[1]]));
  }

  // The arm at its present joints, with each joint's limits.
  const q = S.state ? S.state.joints : null;
  if (q) {
    const { pts } = fkPoints(q);
    let phi = 0;
    for (let i = 0; i < S.limits.length && i < pts.length - 1; i++) {
      const [px, py] = toCanvas(pts[i][0], pts[i][1]);
      const lim = S.limits[i];
      // Allowed range, relative to the previous link (canvas y is down: negate angles).
      ctx.fillStyle = "rgba(31, 122, 58, 0.10)";
      ctx.beginPath(); ctx.moveTo(px, py);
      ctx.arc(px, py, 26, -(phi + lim[1]), -(phi + lim[0])); ctx.closePath(); ctx.fill();
      ctx.strokeStyle = "#b3261e"; ctx.lineWidth = 1.5;
      for (const a of lim) {
        ctx.beginPath(); ctx.moveTo(px, py);
        ctx.lineTo(px + 28 * Math.cos(phi + a), py - 28 * Math.sin(phi + a)); ctx.stroke();
      }
      phi += q[i];
    }
    ctx.strokeStyle = "#38404a"; ctx.lineWidth = 7; ctx.lineCap = "round";
    polyline(ctx, pts);
    ctx.lineCap = "butt";
    for (const [x, y] of pts.slice(0, -1)) {
      const [px, py] = toCanvas(x, y);
      ctx.fillStyle = "#fff"; ctx.strokeStyle = "#38404a"; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.arc(px, py, 5, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    }
    const [bx, by] = toCanvas(0, 0);
    ctx.fillStyle = "#38404a"; ctx.fillRect(bx - 10, by - 10, 20, 20);
    drawFrame(ctx, S.state.pose, 30, 1);
  }
  // The target tool frame: drag the ring to move it, the handle to turn it.
  if (S.target) {
    drawFrame(ctx, S.target, HANDLE_PX, 0.55);
    const [tx, ty] = toCanvas(S.target[0], S.target[1]);
    const [hx, hy] = handlePoint();
    ctx.strokeStyle = "#d12b2b"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.arc(tx, ty, 9, 0, 2 * Math.PI); ctx.stroke();
    ctx.fillStyle = "#d12b2b";
    ctx.beginPath(); ctx.arc(hx, hy, 6, 0, 2 * Math.PI); ctx.fill();
  }
}

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

function drawPlots() {
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

// -- target, inputs -------------------------------------------------------------------------

function setTarget(pose, { fromInputs = false } = {}) {
  S.target = pose;
  if (!fromInputs) {
    $("target-x").value = pose[0].toFixed(3);
    $("target-y").value = pose[1].toFixed(3);
    $("target-theta").value = (pose[2] / DEG).toFixed(1);
  }
  redraw();
}

function readInputs() {
  const x = parseFloat($("target-x").value), y = parseFloat($("target-y").value);
  const th = parseFloat($("target-theta").value);
  if (![x, y, th].every(Number.isFinite)) return false;
  setTarget([x, y, th * DEG], { fromInputs: true });
  return true;
}

function duration() {
  const v = $("duration").value.trim();
  if (v === "" || v === "auto") return "auto";
  const d = Number(v);
  return Number.isFinite(d) ? d : v;  // the service names a bad value
}

function planBody(method) {
  const body = { waypoints: [presentPose(), S.target.slice()], method, duration: duration() };
  if (method === "kenlerp") body.beta = parseFloat($("beta").value);
  return body;
}

let previewTimer = null;
function schedulePreview() {
  clearTimeout(previewTimer);
  previewTimer = setTimeout(preview, 250);
}

function markOf(error, body) {
  // Where an infeasible plan fails: its pose when the error gives one, else the waypoint.
  if (Array.isArray(error.pose) && error.pose.length >= 2) return error.pose;
  const m = /^waypoints\[(\d+)\]/.exec(error.field || "");
  if (m && body.waypoints[+m[1]]) return body.waypoints[+m[1]];
  if (Array.isArray(error.value) && error.value.length === 3 && error.value.every(Number.isFinite)) return error.value;
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

async function failure(error, body) {
  // A failed plan and where on the canvas it fails (null when the error cannot say).
  return { error, body, mark: markOf(error, body) || await locateSample(error, body) };
}

async function preview() {
  if (!readInputs()) { showError({ message: "x, y and θ must be numbers", field: "target" }); return; }
  const main = $("method").value;
  const methods = [main, ...[...document.querySelectorAll(".overlay-method:checked")]
    .map((e) => e.value).filter((m) => m !== main)];
  const seq = (S.previewSeq = (S.previewSeq || 0) + 1);
  const results = await Promise.all(methods.map(async (m) => {
    const body = planBody(m);
    if (S.state) body.start_joints = S.state.joints;
    try { return [m, { traj: await api("POST", "/v1/trajectories", body), body }]; }
    catch (e) { return [m, await failure(e.error, body)]; }
  }));
  if (seq !== S.previewSeq) return;  // a newer preview was asked for meanwhile
  S.plans = Object.fromEntries(results);
  S.planOrder = methods;
  // Built node by node: the page's Content-Security-Policy forbids inline style markup.
  const tbody = $("plans").querySelector("tbody");
  tbody.replaceChildren(...results.map(([m, p]) => {
    const tr = document.createElement("tr");
    tr.dataset.method = m;
    const cell = (text, cls) => {
      const td = document.createElement("td");
      td.textContent = text;
      if (cls) td.className = cls;
      tr.appendChild(td);
      return td;
    };
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = COLORS[m];
    cell("").appendChild(swatch);
    cell(NAMES[m] + (m === "kenlerp" ? " β=" + parseFloat($("beta").value).toFixed(2) : ""));
    cell(p.traj ? `${p.traj.t[p.traj.t.length - 1].toFixed(2)} s` : "–");
    if (p.traj) cell(`feasible · ${p.traj.t.length} samples`, "ok");
    else cell(p.error.code || "infeasible", "bad").title = p.error.message;
    return tr;
  }));
  const failed = results.filter(([, p]) => p.error);
  if (failed.length) showError(failed.map(([m, p]) => (failed.length > 1 || m !== main ? NAMES[m] + ": " : "") + p.error.message).join("\n"));
  else clearError();
  redraw();
}

// -- control ------------------------------------------------------------------------------------

function moveActive() {
  return !!(S.move && ACTIVE.includes(S.move.status));
}

async function startMove() {
  if (!readInputs()) { showError({ message: "x, y and θ must be numbers", field: "target" }); return; }
  clearError();
  const body = planBody($("method").value);
  const before = S.state ? S.state.joints.slice() : null;
  const retarget = moveActive() && S.features.replace;
  if (retarget) body.replace = true;
  try {
    const info = await api("POST", "/v1/moves", body);
    trackMove(info.id);
    setMove(info);
    // The plan the move runs, for the plots: the same request from the same joints.
    delete body.replace;
    if (before && !retarget) body.start_joints = before;
    api("POST", "/v1/trajectories", body).then((t) => {
      if (S.trackedMove === info.id) { S.movePlan = t; redraw(); }
    }).catch(() => {});
  } catch (e) {
    showError(e.error);
    if (e.status === 422) {  // show where the refused plan fails
      const m = $("method").value;
      if (S.state) body.start_joints = S.state.joints;
      delete body.replace;
      S.plans = { [m]: await failure(e.error, body) };
      S.planOrder = [m];
      redraw();
    }
  }
}

async function post(path, body) {
  try { clearError(); return await api("POST", path, body); } catch (e) { showError(e.error); return null; }
}

function stop(kind) {
  const mode = kind === "hold" ? S.features.holdStop : S.features.smoothStop;
  return post("/v1/stop", mode ? { mode } : undefined);
}

function jog(dir) {
  const step = (parseFloat($("jog-step").value) || 1) / 100;
  const base = moveActive() && S.features.replace && S.target ? S.target.slice() : presentPose();
  const d = { "+x": [step, 0, 0], "-x": [-step, 0, 0], "+y": [0, step, 0], "-y": [0, -step, 0],
    "+t": [0, 0, 5 * DEG], "-t": [0, 0, -5 * DEG] }[dir];
  if (moveActive() && !S.features.replace) {
    showError("a move is running: this service cannot retarget it (no \"replace\"); stop it first");
    return;
  }
  setTarget([base[0] + d[0], base[1] + d[1], base[2] + d[2]]);
  startMove();
}

// -- status, readouts ---------------------------------------------------------------------------

function showError(err) {
  const text = typeof err === "string" ? err : (err && err.message) || "error";
  $("error").textContent = text;
}
function clearError() { $("error").textContent = ""; }

function showTokenBox() {
  $("token-box").hidden = false;
}

function trackMove(id) {
  if (S.trackedMove === id) return;
  S.trackedMove = id;
  S.measured = [];
  S.movePlan = null;
}

function setMove(info) {
  if (!info) return;
  if (S.move && Number(info.id) < Number(S.move.id)) return;  // an older move's news
  const was = S.move;
  S.move = { ...(S.move && S.move.id === info.id ? S.move : {}), ...info };
  const el = $("move-status");
  el.textContent = info.status;
  el.className = "pill " + info.status;
  el.dataset.moveId = info.id;
  el.title = `move ${info.id}`;
  $("move-progress").textContent = ACTIVE.includes(info.status) || info.status === "done"
    ? `${Math.round(100 * (info.progress || 0))} %` : "";
  if (info.status === "failed" && info.error && (!was || was.status !== "failed" || was.id !== info.id)) {
    showError(info.error);
  }
  updateButtons();
}

function updateButtons() {
  const arm = S.hasArm, active = moveActive();
  $("move").disabled = !arm || (active && !S.features.replace);
  $("stop").disabled = !arm;
  $("hold").disabled = !arm;
  $("pause").hidden = !S.features.pause;
  $("resume").hidden = !S.features.resume;
  $("pause").disabled = !active;
  $("resume").disabled = !arm;
  $("speed-box").hidden = !S.features.speed;
  $("torque-row").hidden = !S.features.torque;
  document.querySelectorAll("[data-jog]").forEach((b) => { b.disabled = !arm || (active && !S.features.replace); });
}

function onState(st) {
  S.state = st;
  const s = S.stats;
  s.state++;
  s.stamps.push(performance.now());
  if (s.stamps.length > 400) s.stamps.splice(0, s.stamps.length - 400);
  if (!S.target) setTarget(st.pose.slice());
  $("joints").textContent = st.joints.map((q) => (q / DEG).toFixed(1) + "°").join(", ");
  $("pose").textContent = `x ${st.pose[0].toFixed(3)} m, y ${st.pose[1].toFixed(3)} m, θ ${(st.pose[2] / DEG).toFixed(1)}°`;
  const tq = $("torque-state");
  tq.textContent = st.torque === true ? "torque on" : st.torque === false ? "torque off" : "torque ?";
  tq.className = "pill " + (st.torque ? "ok" : "");
  const mi = st.move_info;
  if (mi) {
    if (ACTIVE.includes(mi.status)) {
      trackMove(mi.id);
      S.measured.push({ t: mi.elapsed || 0, q: st.joints, pose: st.pose, err: mi.tracking_error,
        current: st.current });
    }
    setMove(mi);
  }
  redraw();
}

function onAlert(a) {
  const el = $("alerts");
  const parts = Object.entries(a.alerts || {}).map(([id, text]) => `servo ${id}: ${text}`);
  if (a.error) parts.push(a.error.message);
  el.textContent = parts.join("\n");
  el.hidden = !parts.length;
}

function setLink(text, ok) {
  const el = $("link");
  el.textContent = text;
  el.className = "pill " + (ok ? "ok" : "bad");
}

function connect() {
  if (S.es) S.es.close();
  const es = new EventSource("/v1/events");
  S.es = es;
  es.onopen = () => { S.backoff = 1000; setLink("live", true); };
  es.onerror = () => {
    setLink("reconnecting…", false);
    // The browser retries by itself after a dropped stream; after a refusal (503) it gives
    // up (CLOSED): then reconnect here, backing off.
    if (es.readyState === EventSource.CLOSED) {
      setTimeout(() => { if (S.es === es) connect(); }, S.backoff);
      S.backoff = Math.min(2 * S.backoff, 10000);
    }
  };
  es.addEventListener("state", (ev) => onState(JSON.parse(ev.data)));
  es.addEventListener("move", (ev) => { S.stats.move++; setMove(JSON.parse(ev.data)); });
  es.addEventListener("alert", (ev) => { S.stats.alert++; onAlert(JSON.parse(ev.data)); });
}

// -- pointer, wheel, keyboard -------------------------------------------------------------------

function canvasPoint(ev) {
  const c = $("arm-canvas"), r = c.getBoundingClientRect();
  return [(ev.clientX - r.left) * c.width / r.width, (ev.clientY - r.top) * c.height / r.height];
}

function bindCanvas() {
  const c = $("arm-canvas");
  c.addEventListener("pointerdown", (ev) => {
    if (!S.target) return;
    const [px, py] = canvasPoint(ev);
    const [hx, hy] = handlePoint();
    const [tx, ty] = toCanvas(S.target[0], S.target[1]);
    if (Math.hypot(px - hx, py - hy) < 11) S.drag = "turn";
    else {
      S.drag = "move";
      if (Math.hypot(px - tx, py - ty) > 14) {  // a click elsewhere puts the target there
        const [x, y] = toWorld(px, py);
        setTarget([x, y, S.target[2]]);
      }
      S.dragOffset = [px - toCanvas(S.target[0], S.target[1])[0], py - toCanvas(S.target[0], S.target[1])[1]];
    }
    c.setPointerCapture(ev.pointerId);
    ev.preventDefault();
  });
  c.addEventListener("pointermove", (ev) => {
    if (!S.drag) return;
    const [px, py] = canvasPoint(ev);
    if (S.drag === "turn") {
      const [tx, ty] = toCanvas(S.target[0], S.target[1]);
      setTarget([S.target[0], S.target[1], Math.atan2(-(py - ty), px - tx)]);
    } else {
      const [x, y] = toWorld(px - S.dragOffset[0], py - S.dragOffset[1]);
      setTarget([x, y, S.target[2]]);
    }
  });
  const end = () => { if (S.drag) { S.drag = null; schedulePreview(); } };
  c.addEventListener("pointerup", end);
  c.addEventListener("pointercancel", end);
  c.addEventListener("wheel", (ev) => {
    if (!S.target) return;
    ev.preventDefault();
    setTarget([S.target[0], S.target[1], S.target[2] + Math.sign(-ev.deltaY) * 5 * DEG]);
    schedulePreview();
  }, { passive: false });
}

function bindKeys() {
  const keys = { ArrowLeft: "-x", ArrowRight: "+x", ArrowUp: "+y", ArrowDown: "-y", q: "+t", e: "-t" };
  document.addEventListener("keydown", (ev) => {
    const tag = (ev.target && ev.target.tagName) || "";
    if (["INPUT", "SELECT", "TEXTAREA"].includes(tag) || ev.ctrlKey || ev.metaKey || ev.altKey) return;
    if (ev.key === "Escape") { stop("smooth"); ev.preventDefault(); return; }
    const dir = keys[ev.key] || keys[ev.key.toLowerCase()];
    if (dir && S.hasArm) { jog(dir); ev.preventDefault(); }
  });
}

function bindControls() {
  $("preview").addEventListener("click", preview);
  $("move").addEventListener("click", startMove);
  $("stop").addEventListener("click", () => stop("smooth"));
  $("hold").addEventListener("click", () => stop("hold"));
  $("pause").addEventListener("click", () => post("/v1/pause", {}));
  $("resume").addEventListener("click", () => post("/v1/resume", {}));
  $("speed").addEventListener("input", () => {
    $("speed-value").textContent = `${Math.round(100 * parseFloat($("speed").value))} %`;
  });
  $("speed").addEventListener("change", () => {
    api("PUT", "/v1/speed", { [S.features.speed]: parseFloat($("speed").value) }).catch((e) => showError(e.error));
  });
  $("torque-on").addEventListener("click", () => post("/v1/torque", { [S.features.torque]: true }));
  $("torque-off").addEventListener("click", () => post("/v1/torque", { [S.features.torque]: false }));
  document.querySelectorAll("[data-jog]").forEach((b) => b.addEventListener("click", () => jog(b.dataset.jog)));
  for (const id of ["target-x", "target-y", "target-theta"]) {
    $(id).addEventListener("input", () => { if (readInputs()) schedulePreview(); });
  }
  $("method").addEventListener("change", schedulePreview);
  $("duration").addEventListener("change", schedulePreview);
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
  const cfg = S.arm.config;
  S.links = cfg.arm.links;
  S.dof = S.arm.dof;
  S.limits = cfg.joints.map((j) => [j.min, j.max]);
  S.home = [cfg.arm.home.x, cfg.arm.home.y, cfg.arm.home.theta];
  $("arm-name").textContent = S.arm.name;
  const sr = S.features.speedRange;
  $("speed").min = sr[0]; $("speed").max = sr[1];
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
window.robodcnConsole = { S, toCanvas, preview, draw: drawArm, stats: S.stats };
document.addEventListener("DOMContentLoaded", init);
