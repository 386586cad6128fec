// The console's one shared state and its constants. Every other module reads and writes S;
// none keeps state of its own beyond timers.

export const DEG = Math.PI / 180;
export const COLORS = { sclerp: "#2457c5", kenlerp: "#c2410c", seplerp: "#15803d", dlb: "#7e22ce" };
export const NAMES = { sclerp: "ScLERP", kenlerp: "KenLERP", seplerp: "SEP-LERP", dlb: "DLB" };
export const JOINT_COLORS = ["#2457c5", "#c2410c", "#15803d", "#7e22ce", "#0e7490", "#a16207"];
/** Move statuses of a move that has not ended (following: a follow session, a live drag). */
export const ACTIVE = ["queued", "running", "following"];

export const S = {
  api: null, arm: null, features: {}, hasArm: true,
  token: sessionStorage.getItem("robodcn-token") || "", tokenRequired: false,
  // The arm's model (geometry.js: loadArm): planar links or a yawed chain.
  model: null, limits: [], dof: 0, home: [0, 0, 0],
  state: null, move: null, target: null, sent: null,   // sent: {id, pose} of the last move
  plans: {}, planOrder: [], movePlan: null, measured: [],
  trackedMove: null, es: null, backoff: 1000, drag: null, dragOffset: null,
  speedEditing: false, previewSeq: 0,
  stats: { state: 0, move: 0, alert: 0, stamps: [] },
};

export const $ = (id) => document.getElementById(id);

/** True while the latest move is queued or running. */
export function moveActive() {
  return !!(S.move && ACTIVE.includes(S.move.status));
}
