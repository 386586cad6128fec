// The arm's model as the page draws it, from GET /v1/arm: a planar chain whose poses are
// (x, y, θ), or a base yaw turning a chain in a vertical plane whose poses are
// (x, y, z, pitch) (issue 18; robodcn/kinematics/_yawed.py). The drawing plane is (x, y) of
// a planar arm and (r, z) of a yawed one: (u, v) below, with the tool angle θ or pitch.
import { DEG } from "./state.js";

const PLANAR_AXES = ["x", "y", "theta"];
const YAWED_AXES = ["x", "y", "z", "pitch"];

/**
 * The model of GET /v1/arm. A yawed arm is announced by `pose_axes` (["x","y","z","pitch"]),
 * `yawed: true` or its config's `arm.base_yaw`; anything else is planar (x, y, θ).
 * Yawed chain links are the vectors (a, b) from each joint to the next at zero (a length
 * alone is (L, 0)); planar links are lengths.
 */
export function loadArm(arm) {
  const cfg = (arm.config && arm.config.arm) || {};
  let axes = Array.isArray(arm.pose_axes) && arm.pose_axes.length >= 3 ? arm.pose_axes.slice()
    : (arm.yawed === true || cfg.base_yaw === true) ? YAWED_AXES.slice() : PLANAR_AXES.slice();
  const yawed = axes.includes("z");
  if (yawed && axes.length !== 4) axes = YAWED_AXES.slice();
  const raw = cfg.links || [];
  const vectors = raw.map((l) => (Array.isArray(l) ? [Number(l[0]), Number(l[1])] : [Number(l), 0]));
  const lengths = vectors.map(([a, b]) => Math.hypot(a, b));
  const home = cfg.home || {};
  return {
    yawed, axes,
    angleIndex: yawed ? 3 : 2,             // θ or pitch in a pose
    angleName: yawed ? "pitch" : "θ",
    lengths,
    offsets: yawed ? vectors.map(([a, b]) => Math.atan2(b, a)) : lengths.map(() => 0),
    height: yawed ? Number(cfg.shoulder_height || 0) : 0,
    reach: lengths.reduce((a, b) => a + b, 0) || 0.5,
    home: axes.map((k) => Number(home[k] ?? 0) || 0),
    // keep-out zones (zones.js), as GET /v1/arm lists them
    zones: Array.isArray(arm.keep_out) ? arm.keep_out : [],
  };
}

/** The chain's joints of a joint vector: a yawed arm's yaw comes first. */
export function chainJoints(model, q) {
  return model.yawed ? q.slice(1) : q;
}

/** The yaw (rad) of a joint vector (0 on a planar arm). */
export function yawOf(model, q) {
  return model.yawed ? q[0] || 0 : 0;
}

/**
 * Joint points from the base to the tool point in the drawing plane, and each chain
 * joint's direction law dir(i, q) = the absolute angle of link i at joint angle q.
 * Planar: φ_i = Σ q, points (Σ l cos φ, Σ l sin φ). Yawed (ROBOTIS sign, positive = forward
 * and down): ψ_i = α_i − Σ q, points (Σ L cos ψ, h + Σ L sin ψ).
 */
export function chainPoints(model, q) {
  const c = chainJoints(model, q);
  const sign = model.yawed ? -1 : 1;
  const pts = [[0, model.height]], before = [];
  let sum = 0, u = 0, v = model.height;
  for (let i = 0; i < model.lengths.length; i++) {
    before.push(sum);
    sum += c[i] || 0;
    const psi = model.offsets[i] + sign * sum;
    u += model.lengths[i] * Math.cos(psi);
    v += model.lengths[i] * Math.sin(psi);
    pts.push([u, v]);
  }
  const dir = (i, qi) => model.offsets[i] + sign * (before[i] + qi);
  return { pts, dir };
}

/** A pose in the drawing plane: [u, v, angle] (planar: x, y, θ; yawed: r, z, pitch). */
export function toPlane(model, pose) {
  if (!model.yawed) return [pose[0], pose[1], pose[2] || 0];
  return [Math.hypot(pose[0], pose[1]), pose[2], pose[3]];
}

/** The yaw of a pose: atan2(y, x), or `fallback` on the yaw axis. */
export function poseYaw(model, pose, fallback = 0) {
  if (!model.yawed) return 0;
  return Math.hypot(pose[0], pose[1]) < 1e-6 ? fallback : Math.atan2(pose[1], pose[0]);
}

/** A pose from plane coordinates [u, v, angle] at `yaw`: the inverse of toPlane. On a
 * yawed arm r stays in front of the base (≥ 5 mm): behind it is the refused branch. */
export function fromPlane(model, [u, v, angle], yaw = 0) {
  if (!model.yawed) return [u, v, angle];
  const r = Math.max(0.005, u);
  return [r * Math.cos(yaw), r * Math.sin(yaw), v, angle];
}

/** A pose in the user's units: "x 0.120 m, y 0.240 m, θ 60.0°" (or z and pitch). */
export function poseText(model, pose) {
  return model.axes.map((k, i) => {
    const angle = k === "theta" || k === "pitch";
    const name = k === "theta" ? "θ" : k;
    return angle ? `${name} ${((pose[i] || 0) / DEG).toFixed(1)}°` : `${name} ${(pose[i] || 0).toFixed(3)} m`;
  }).join(", ");
}

/** Scale and origin of a canvas showing the drawing plane: the planar arm's base at the
 * centre; the side view of a yawed arm with room behind the base and below the plate. */
export function view(model, canvas) {
  const R = model.reach;
  if (!model.yawed) {
    const k = Math.min(canvas.width, canvas.height) / (2 * R * 1.12);
    return { k, ox: canvas.width / 2, oy: canvas.height / 2 };
  }
  const k = Math.min(canvas.width / (1.5 * R), canvas.height / (1.35 * R + model.height));
  return { k, ox: 0.32 * R * k, oy: canvas.height - 0.18 * R * k };
}

/** Scale and origin of the top view (x, y) of a yawed arm: the yaw axis at the centre. */
export function topView(model, canvas) {
  const k = Math.min(canvas.width, canvas.height) / (2 * model.reach * 1.12);
  return { k, ox: canvas.width / 2, oy: canvas.height / 2 };
}
