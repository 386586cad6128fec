// The service: JSON requests with the bearer token, and what its OpenAPI document says it
// offers (GET /openapi.json): optional routes, stop modes, and the ranges of body fields, so
// that no control of the page can drift from the contract.
import { S } from "./state.js";
import { showTokenBox } from "./ui.js";

/** A JSON request; throws {status, error} with the service's error body on failure. Every
 * request that changes something (POST, PUT, DELETE) carries a JSON body, {} when it has no
 * fields: the service refuses any other (415), so that no foreign page can send one.
 * `keepalive`: the request outlives the page (sent as it closes). */
export async function api(method, path, body, { keepalive = false } = {}) {
  if (method !== "GET" && body === undefined) body = {};
  if (method !== "GET" && S.tokenRequired && !S.token) {
    showTokenBox();
    throw { status: 401, error: { code: "unauthorized", field: "token",
      message: "this server needs a token: enter it in the token field (top right)" } };
  }
  const headers = {};
  if (body !== undefined) headers["Content-Type"] = "application/json";
  if (method !== "GET" && S.token) headers.Authorization = "Bearer " + S.token;
  const r = await fetch(path, { method, headers, keepalive,
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

/** The OpenAPI operation object of (path, method), or null when the service lacks it. */
export function op(path, method) {
  const p = S.api && S.api.paths && S.api.paths[path];
  return (p && p[method]) || null;
}

function deref(schema) {
  if (schema && schema.$ref) return S.api.components.schemas[schema.$ref.split("/").pop()] || {};
  return schema || {};
}

/** The JSON request body schema of (path, method) with its $ref resolved, or null. */
export function bodySchema(path, method) {
  const o = op(path, method);
  const content = o && o.requestBody && o.requestBody.content;
  const schema = content && content["application/json"] && content["application/json"].schema;
  return schema ? deref(schema) : null;
}

/** The properties of a body; of a body of several forms (anyOf/oneOf, e.g. waypoints or a
 * given trajectory), every form's. */
export function bodyProps(path, method) {
  const schema = bodySchema(path, method);
  const forms = schema && !schema.properties && (schema.anyOf || schema.oneOf);
  if (forms) return Object.assign({}, ...forms.map((f) => deref(f).properties || {}));
  return (schema && schema.properties) || {};
}

/** [min, max] of a number schema, or of the first number form of a oneOf/anyOf (a scalar
 * or a per-segment list); an exclusive bound moves in by `step`. Null without bounds. */
export function numberRange(schema, step = 0) {
  if (!schema) return null;
  const forms = schema.oneOf || schema.anyOf;
  if (forms) {
    for (const f of forms) { const r = numberRange(deref(f), step); if (r) return r; }
    return null;
  }
  if (!["number", "integer"].includes(schema.type)) return null;
  const lo = schema.minimum ?? (schema.exclusiveMinimum !== undefined ? schema.exclusiveMinimum + step : null);
  const hi = schema.maximum ?? (schema.exclusiveMaximum !== undefined ? schema.exclusiveMaximum - step : null);
  return lo === null || hi === null ? null : [lo, hi];
}

function enumOf(schema) {
  if (!schema) return [];
  return schema.enum || (schema.oneOf || schema.anyOf || []).flatMap((s) => deref(s).enum || []);
}

function pick(options, wanted) {
  return wanted.find((w) => options.includes(w)) || null;
}

/** S.features from the OpenAPI document: what the page may offer. */
export function detectFeatures() {
  const f = {};
  const modes = enumOf(bodyProps("/v1/stop", "post").mode);
  f.smoothStop = pick(modes, ["smooth", "decelerate", "ramp", "soft"]);
  f.holdStop = pick(modes, ["hold", "immediate", "now", "hard"]);
  const move = bodyProps("/v1/moves", "post");
  f.replace = "replace" in move;
  // A one-waypoint body ("from the present state") where the contract allows it.
  f.oneWaypoint = !!(move.waypoints && move.waypoints.minItems !== undefined &&
    move.waypoints.minItems <= 1);
  f.moveTrajectory = !!op("/v1/moves/{id}/trajectory", "get");
  f.pause = !!op("/v1/pause", "post");
  f.resume = !!op("/v1/resume", "post");
  // Follow sessions (a drag moves the arm live): follow_open, follow_target and follow_end,
  // with pose targets.
  const opened = op("/v1/follow", "post"), sent = op("/v1/follow/target", "put");
  const ended = op("/v1/follow", "delete");
  f.follow = !!(opened && opened.operationId === "follow_open" && sent &&
    sent.operationId === "follow_target" && ended && ended.operationId === "follow_end" &&
    enumOf(bodyProps("/v1/follow", "post").space).includes("pose") &&
    "pose" in bodyProps("/v1/follow/target", "put"));
  const speed = bodyProps("/v1/speed", "put");
  f.speed = op("/v1/speed", "put") ? (Object.keys(speed).find((k) =>
    ["number", "integer"].includes(speed[k].type)) || "speed") : null;
  // an exclusive minimum (0 < k) is not a value to send: the slider starts one step above it
  f.speedRange = (f.speed && numberRange(speed[f.speed], 0.05)) || [0.05, 1];
  const plan = bodyProps("/v1/trajectories", "post");
  f.betaRange = numberRange(plan.beta);
  // the tool's speed limit (hands-on: 250 mm/s by default), at most the arm's ceiling
  f.toolSpeed = "tool_speed" in plan;
  f.toolSpeedMax = f.toolSpeed && typeof plan.tool_speed.maximum === "number"
    ? plan.tool_speed.maximum : null;
  const torque = bodyProps("/v1/torque", "post");
  f.torque = op("/v1/torque", "post") ? (Object.keys(torque).find((k) =>
    torque[k].type === "boolean" && k !== "confirm") || "enabled") : null;
  // Torque off on an arm under gravity asks to be confirmed (409 gravity_release otherwise).
  f.torqueConfirm = f.torque && torque.confirm && torque.confirm.type === "boolean" ? "confirm" : null;
  const gripper = bodyProps("/v1/gripper", "post");
  f.gripper = op("/v1/gripper", "post") ? {
    commands: enumOf(gripper.command), width: "width_m" in gripper,
    widthRange: numberRange(gripper.width_m) } : null;
  S.features = f;
  S.tokenRequired = !!(S.api.components && S.api.components.securitySchemes &&
    S.api.components.securitySchemes.bearer);
}
