"""Trajectory: a validated plan's samples, with its JSON and CSV forms."""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robodcn import _checks
from robodcn.config import PLANAR_POSE, RATE_RANGE, YAWED_POSE, Arm
from robodcn.contract.request import PlanRequest, StartState
from robodcn.errors import InputError
from robodcn.planner import arm_arrays


@dataclass(eq=False)
class Trajectory:
    """A validated plan: samples every 1/rate_hz s from t = 0.

    Attributes
    ----------
    t : (n,) seconds; poses : (n, 3) (x, y, θ) with θ continuous (for a 2-joint arm θ plays
    no part in the plan and is FK's q1 + q2), or for an arm with a base yaw (n, 4)
    (x, y, z, pitch) in its base frame; joints : (n, k) radians, unwrapped;
    ticks : (n, k) int64 goal positions; joint_names, servo_ids : k each; rate_hz; method
    (the request's, a string or a list per segment); request; elbow : the IK branch at the
    first sample ("up" q2 < 0, "down" q2 > 0, None when stretched out or folded there);
    branch_switches : sample indices where the elbow branch differs from the one before
    (through a singular pose; empty for almost every plan); approach_samples : sample
    periods of the joint-space approach prepended from start_joints (0: none), so the
    approach lasts ``approach_duration`` seconds from t = 0; start_state : the moving
    :class:`StartState` the plan starts from (its sample 0 is those joints, its velocity and
    acceleration continue them), or None (from rest); pose_keys : the names of a pose row,
    ("x", "y", "theta") or ("x", "y", "z", "pitch") (derived from the request's arm, else
    from the poses' width, when not given).
    """

    t: NDArray[np.float64] = field(metadata={
        "description": "Sample times (s), from 0 in steps of exactly 1/rate_hz.",
        "schema": {"type": "array", "minItems": 1, "items": {"type": "number"}}})
    poses: NDArray[np.float64] = field(metadata={
        "description": "Pose per sample: [x, y, θ] (m, m, rad, θ continuous), or on an arm "
                       "with a base yaw [x, y, z, pitch] (m, m, m, rad) in its base frame "
                       "(pose_keys names them).",
        "schema": {"type": "array", "items": {"type": "array", "minItems": 3, "maxItems": 4,
                                              "items": {"type": "number"}}}})
    joints: NDArray[np.float64] = field(metadata={
        "description": "Joint angles per sample (rad, unwrapped), one per joint.",
        "schema": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}}})
    ticks: NDArray[np.int64] = field(metadata={
        "description": "Servo goal positions per sample (ticks), one per servo.",
        "schema": {"type": "array",
                   "items": {"type": "array", "items": {"type": "integer"}}}})
    joint_names: tuple[str, ...] = field(metadata={"description": "Joint names, base first."})
    servo_ids: tuple[int, ...] = field(metadata={"description": "Servo ids in joint order."})
    rate_hz: float = field(metadata={"description": "Sample rate (Hz)."})
    method: str | list[str] = field(metadata={
        "description": "Interpolation method, or one per segment."})
    request: PlanRequest | None = field(default=None, metadata={
        "description": "The request that was planned (the arm embedded, SI units).",
        "schema": {"type": ["object", "null"]}})
    elbow: str | None = field(default=None, metadata={
        "description": "IK branch at the first sample: up (q2 < 0), down (q2 > 0), or null "
                       "when stretched out or folded there.",
        "schema": {"enum": ["up", "down", None]}})
    branch_switches: tuple[int, ...] = field(default=(), metadata={
        "description": "Samples where the elbow branch changes (passing a singular pose)."})
    approach_samples: int = field(default=0, metadata={
        "description": "Sample periods of the joint-space approach from start_joints that "
                       "opens the plan (0: none); it lasts approach_samples / rate_hz s."})
    start_state: StartState | None = field(default=None, metadata={
        "description": "The moving joint state the plan starts from (joints rad, velocities "
                       "rad/s, accelerations rad/s²), or null: from rest.",
        "schema": {"type": ["object", "null"]}})
    pose_keys: tuple[str, ...] = field(default=(), metadata={
        "description": "Names of a pose row's numbers: [x, y, theta], or [x, y, z, pitch] on "
                       "an arm with a base yaw.",
        "schema": {"enum": [list(PLANAR_POSE), list(YAWED_POSE)]}})

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=np.float64)
        self.poses = np.asarray(self.poses, dtype=np.float64)
        self.joints = np.asarray(self.joints, dtype=np.float64)
        ticks = np.asarray(self.ticks)
        if ticks.size and not np.issubdtype(ticks.dtype, np.integer):
            if not np.array_equal(ticks, np.round(ticks)):
                raise InputError("ticks must be integers", field="ticks", value=None)
        self.ticks = ticks.astype(np.int64)
        self.joint_names = tuple(self.joint_names)
        self.servo_ids = tuple(int(i) for i in self.servo_ids)
        self.branch_switches = tuple(int(i) for i in self.branch_switches)
        self.approach_samples = int(self.approach_samples)
        n = self.t.shape[0] if self.t.ndim == 1 else -1
        k = len(self.joint_names)
        if self.request is not None:
            keys = self.request.arm.pose_keys
        else:  # a yawed arm's four numbers, else a planar arm's three
            keys = YAWED_POSE if self.poses.ndim == 2 and self.poses.shape[1] == 4 \
                else PLANAR_POSE
        if self.pose_keys and tuple(self.pose_keys) != keys:
            raise InputError(f"pose_keys must be {list(keys)} for these poses, got "
                             f"{list(self.pose_keys)}", field="pose_keys",
                             value=list(self.pose_keys))
        self.pose_keys = keys
        width = len(keys)
        for name, array, shape in (("t", self.t, (n,)), ("poses", self.poses, (n, width)),
                                   ("joints", self.joints, (n, k)),
                                   ("ticks", self.ticks, (n, k))):
            if n < 1 or array.shape != shape:
                raise InputError(f"trajectory {name} must have shape {shape} (n ≥ 1 samples, "
                                 f"k = {k} joints), got {array.shape}", field=name,
                                 value=array.shape)
        if len(self.servo_ids) != k:
            raise InputError(f"servo_ids must name {k} servos, got {len(self.servo_ids)}",
                             field="servo_ids", value=self.servo_ids)
        if not _checks.is_real(self.rate_hz) or not RATE_RANGE[0] <= self.rate_hz <= RATE_RANGE[1]:
            raise InputError(f"rate_hz must be within {RATE_RANGE[0]:g}..{RATE_RANGE[1]:g} Hz, "
                             f"got {self.rate_hz!r}", field="rate_hz", value=self.rate_hz)
        self.rate_hz = float(self.rate_hz)
        expected = np.arange(n) / self.rate_hz
        if np.abs(self.t - expected).max() > 1e-9:
            raise InputError("t must start at 0 and step by exactly 1/rate_hz", field="t",
                             value=None)
        for name, array in (("poses", self.poses), ("joints", self.joints)):
            if not np.isfinite(array).all():
                raise InputError(f"trajectory {name} must be finite", field=name, value=None)

    @property
    def duration(self) -> float:
        """t[-1], seconds."""
        return float(self.t[-1])

    @property
    def approach_duration(self) -> float:
        """Seconds of the joint-space approach at the start (0.0 without one)."""
        return self.approach_samples / self.rate_hz

    def to_dict(self) -> dict[str, Any]:
        return {"t": self.t.tolist(), "poses": self.poses.tolist(),
                "joints": self.joints.tolist(), "ticks": self.ticks.tolist(),
                "joint_names": list(self.joint_names), "servo_ids": list(self.servo_ids),
                "rate_hz": self.rate_hz, "method": self.method,
                "request": None if self.request is None else self.request.to_dict(),
                "elbow": self.elbow, "branch_switches": list(self.branch_switches),
                "approach_samples": self.approach_samples,
                "start_state": None if self.start_state is None else self.start_state.to_dict(),
                "pose_keys": list(self.pose_keys)}

    def to_json(self) -> str:
        """JSON with keys t, pose_keys, poses, joints, ticks, joint_names, servo_ids, rate_hz,
        method, request, … (floats written with repr precision: the round trip is exact)."""
        return json.dumps(self.to_dict())

    @classmethod
    def from_json(cls, text: str, arm: Arm | None = None) -> Trajectory:
        """Parse :meth:`to_json` output, checking every shape (InputError naming the key).

        The request is rebuilt with ``arm`` when given, else with the arm embedded in it.
        """
        try:
            data = json.loads(text)
        except (json.JSONDecodeError, TypeError) as exc:
            raise InputError(f"trajectory JSON is invalid: {exc}", field="json",
                             value=None) from exc
        if not isinstance(data, dict):
            raise InputError("trajectory JSON must be an object", field="json", value=None)
        keys = ("t", "poses", "joints", "ticks", "joint_names", "servo_ids", "rate_hz",
                "method")
        for key in keys:
            if key not in data:
                raise InputError(f"trajectory JSON lacks key {key!r}", field=key, value=None)
        if arm is not None and tuple(data["servo_ids"]) != arm.servo_ids:
            raise InputError(f"trajectory servo_ids {data['servo_ids']} do not match arm "
                             f"{arm.name!r} {list(arm.servo_ids)}", field="servo_ids",
                             value=data["servo_ids"])
        request = None
        if data.get("request") is not None:
            request = PlanRequest.from_dict(data["request"], arm)
        arrays = {}
        for key in ("t", "poses", "joints", "ticks"):
            arrays[key] = _checks.finite(key, data[key])
        keys_ = data.get("pose_keys", [])
        if keys_ not in ([], list(PLANAR_POSE), list(YAWED_POSE)):
            raise InputError(f"pose_keys must be {list(PLANAR_POSE)} or {list(YAWED_POSE)}, "
                             f"got {keys_!r}", field="pose_keys", value=keys_)
        width = arrays["poses"].shape[1] if arrays["poses"].ndim == 2 else None
        if arm is not None and width != len(arm.pose_keys):
            raise InputError(f"trajectory poses have {width} numbers a row, arm {arm.name!r} "
                             f"poses {len(arm.pose_keys)} ({', '.join(arm.pose_keys)})",
                             field="poses", value=width)
        names = data["joint_names"]
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise InputError("joint_names must be a list of strings", field="joint_names",
                             value=names)
        elbow = data.get("elbow")
        if elbow not in ("up", "down", None):
            raise InputError("elbow must be up, down or null", field="elbow", value=elbow)
        switches = data.get("branch_switches", [])
        if not isinstance(switches, list) or not all(
                isinstance(i, int) and not isinstance(i, bool) for i in switches):
            raise InputError("branch_switches must be a list of sample indices",
                             field="branch_switches", value=None)
        approach = data.get("approach_samples", 0)
        if isinstance(approach, bool) or not isinstance(approach, int) \
                or not 0 <= approach < arrays["t"].shape[0]:
            raise InputError("approach_samples must be a sample count within the trajectory",
                             field="approach_samples", value=approach)
        state = data.get("start_state")
        if state is not None:
            if not isinstance(state, dict) or not isinstance(state.get("joints"), list):
                raise InputError("start_state must be an object with joints, velocities, "
                                 "accelerations", field="start_state", value=None)
            state = StartState(**{k: _checks.finite(f"start_state.{k}", v).tolist()
                                  for k, v in state.items()
                                  if k in ("joints", "velocities", "accelerations")})
        return cls(arrays["t"], arrays["poses"], arrays["joints"], arrays["ticks"], names,
                   data["servo_ids"], data["rate_hz"], data["method"], request, elbow,
                   tuple(switches), approach, state, tuple(keys_))

    def to_csv(self) -> str:
        """CSV in :func:`csv_rows`' columns (``plan --format csv``, a move's record): SI
        values at full precision, every header naming its unit."""
        return csv_rows(self.pose_keys, self.joint_names, self.servo_ids, self.t,
                        self.poses, self.joints, self.ticks)


#: The angle keys of a pose (radians in a CSV header; the rest are metres).
_ANGLE_KEYS = frozenset({"theta", "pitch"})


def csv_rows(pose_keys: Sequence[str], joint_names: Sequence[str], servo_ids: Sequence[int],
             t: ArrayLike, poses: ArrayLike, joints: ArrayLike, ticks: ArrayLike) -> str:
    """The one CSV of motion samples, planned or measured: t_s, the pose (x_m, y_m,
    theta_rad; a yawed arm's x_m, y_m, z_m, pitch_rad), q_<joint>_rad, tick_<servo id>."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["t_s", *(f"{k}_rad" if k in _ANGLE_KEYS else f"{k}_m" for k in pose_keys),
                     *(f"q_{n}_rad" for n in joint_names), *(f"tick_{i}" for i in servo_ids)])
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    floats = np.column_stack([t, np.asarray(poses, dtype=np.float64).reshape(t.size, -1),
                              np.asarray(joints, dtype=np.float64).reshape(t.size, -1)])
    for row, tick_row in zip(floats.tolist(), np.asarray(ticks).reshape(t.size, -1).tolist(),
                             strict=True):
        writer.writerow([repr(v) for v in row] + [int(k) for k in tick_row])
    return out.getvalue()


_FIELDS = frozenset(f.name for f in fields(Trajectory))


def planned(t: NDArray[np.float64], poses: NDArray[np.float64], joints: NDArray[np.float64],
            ticks: NDArray[np.int64], *, request: PlanRequest, method: str | list[str],
            elbow: str | None, branch_switches: tuple[int, ...], approach_samples: int,
            start_state: StartState | None) -> Trajectory:
    """The planner's own Trajectory of ``request`` (robodcn.planner.build.assemble).

    Its arrays come out of validation as the contract has them — t = arange(n) / rate_hz
    exactly, float64 poses (n, width) and joints (n, k), int64 ticks (n, k), n ≥ 1 — and
    the names, ids and rate are the validated arm's and request's, so the checks and
    conversions of ``__post_init__`` (~7 µs of a small plan) are not repeated. Finiteness
    is still asked, by one sum of each array (finite exactly when every entry is, short of
    an overflow past 1e308, which takes the full construction and its message).
    """
    # (ndarray.sum as the ufunc's reduce, without its wrapper)
    if not (math.isfinite(float(np.add.reduce(poses, axis=None)))
            and math.isfinite(float(np.add.reduce(joints, axis=None)))):
        arm = request.arm
        return Trajectory(t, poses, joints, ticks, arm.joint_names, arm.servo_ids,
                          request.rate_hz, method, request, elbow, branch_switches,
                          approach_samples, start_state)
    arm = request.arm
    consts = arm_arrays.arrays_of(arm)  # the names and ids, built once per arm
    traj = object.__new__(Trajectory)
    values = {"t": t, "poses": poses, "joints": joints, "ticks": ticks,
              "joint_names": consts.joint_names, "servo_ids": consts.servo_ids,
              "rate_hz": request.rate_hz, "method": method, "request": request,
              "elbow": elbow, "branch_switches": branch_switches,
              "approach_samples": approach_samples, "start_state": start_state,
              "pose_keys": arm.pose_keys}
    assert values.keys() == _FIELDS, "planned() sets every field of Trajectory"
    traj.__dict__.update(values)
    return traj
