"""Collision stop: thresholds on each joint's motor current, derived from the plan.

The current a joint should draw along the plan is predicted from the joint torques of the
arm's inverse dynamics (:func:`robodcn.stream.compensation.plan_torques`: gravity, the
payload, the planned acceleration, the rotors) and the servo's motor model
(:mod:`robodcn.stream.servo_model`, i = (u·V − k·q̇)/R). A collision makes the position
loop push against the obstacle, so the current climbs toward the servo's limit while the
plan does not ask for it. The threshold at each sample starts from the current that sample
needs (a loaded vertical arm holds its gravity current all along)::

    I_th(t) = min(2·max_{|s − t| ≤ W} |i_pred(s)| + 0.5 A,  0.9·I_limit)

with W = :data:`WINDOW_S` (a read lands up to a few samples late; the current leads the
plan where the lead ramps in). The report's per-joint threshold is its largest value,
min(2·max_t |i_pred(t)| + 0.5 A, 0.9·I_limit).

(a factor 2 and 0.5 A for model error and for the goal jumps of samples a loaded host had
to skip, which the simulator showed to reach 3× the prediction for a few cycles; a blocked
joint heads for its stall current, 2.3 A on an XM430, well above; below the current limit,
where the firmware's overload would otherwise act first). ``collision_current_a`` per joint in
the arm file, or ``ExecutionOptions.collision_current``, overrides it.

A Current Limit that is not a positive number caps nothing (:func:`current_caps`): the
item only bounds Goal Current in the current-based modes, so a position-mode servo holding
0 there draws its currents all the same, and a misread one — a late status packet of the
Position D Gain read just before it, 0 on an XM430, taken for its answer (status packets
carry no sequence number) — read 0 A. Either would make the threshold 0.9·0 = 0 A and stop
a normal move as a "collision" at its first feedback read; such a joint is capped at
0.9·:data:`FALLBACK_LIMIT_A` instead.

A servo with a Position D Gain (the XL430-W250's factory 4000) answers every streamed goal
step with a derivative kick, PWM = KPD·Δg for one control millisecond, which the read right
after the write catches: its current readings jump to the limit while it follows the plan
well. No default threshold separates that from a collision, so the default stop is off for
such a joint (``inf``; the streamer warns "collision_stop_off"); a configured
``collision_current_a`` still applies. The stream stops when
a joint's |current| stays above its threshold for ``collision_cycles`` consecutive feedback
reads, not counting reads within :data:`SLEW_QUIET_S` of a goal the loop slewed (the current
of the servo chasing it is the loop's doing, not an obstacle's).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm, ServoSpec
from robodcn.servo_models import XM430_W350
from robodcn.stream.compensation import plan_torques
from robodcn.stream.servo_model import derivatives, motor_of

#: Model-error factor and absolute margin of the default threshold (module notes).
MARGIN_FACTOR = 2.0
MARGIN_A = 0.5
#: The default threshold stays below this share of the servo's current limit.
LIMIT_SHARE = 0.9
#: The limit (A) a joint whose Current Limit is not a positive number is capped under:
#: the XM430-W350's stall current, what a bus without Current Limit readings assumes.
FALLBACK_LIMIT_A = XM430_W350.stall_current
#: Half-width of the window a sample's threshold takes its current from, s.
WINDOW_S = 0.05
#: How long after a goal the loop slewed the collision count stays at zero, s: while the
#: loop slews (:mod:`robodcn.stream.step_guard`, after a host stall) the goal runs ahead of
#: the plan at the velocity limit, the servo lags it and pushes at full PWM, a current the
#: plan does not predict; then the arm closes that lag at speed (≈ 100 ticks at 2000
#: ticks/s: 50 ms) and its current decays over the window. The tracking check stays on.
SLEW_QUIET_S = 0.15


def predicted_currents(joints: NDArray[np.float64], period: float,
                       servos: Sequence[ServoSpec], arm: Arm | None,
                       payload_kg: float | None = None) -> NDArray[np.float64]:
    """Motor current (A, joint sign) each joint draws along the plan, (n, k)."""
    joints = np.asarray(joints, dtype=np.float64)
    qd, qdd = derivatives(joints, period)
    torque = plan_torques(arm, servos, joints, qd, qdd, payload_kg)
    return np.column_stack([motor_of(s.model).current_for(qd[:, j], torque[:, j])
                            for j, s in enumerate(servos)])


def current_caps(limits: Sequence[float]) -> NDArray[np.float64]:
    """Per joint the cap of the default threshold, A: :data:`LIMIT_SHARE` of its Current
    Limit, of :data:`FALLBACK_LIMIT_A` where that is not a positive finite number (module
    notes: a 0 there caps nothing; it once made a 0.00 A threshold)."""
    limits = np.asarray(limits, dtype=np.float64)
    usable = np.isfinite(limits) & (limits > 0)
    return LIMIT_SHARE * np.where(usable, limits, FALLBACK_LIMIT_A)


def _window_max(values: NDArray[np.float64], half: int) -> NDArray[np.float64]:
    """max over samples s with |s − t| ≤ half of ``values`` (n, k), per t (vectorised by
    doubling: max over [t, t + 2^m) composed in log₂ steps)."""
    n = len(values)
    if n == 0 or half <= 0:
        return values.copy()
    pad = np.full((half, values.shape[1]), -np.inf)
    run = np.vstack([pad, values, pad])
    width, out = 1, run.copy()
    while width < 2 * half + 1:
        step = min(width, 2 * half + 1 - width)
        out[:len(out) - step] = np.maximum(out[:len(out) - step], out[step:])
        width += step
    return out[:n]


def _overrides(k: int, arm: Arm | None, d_gains: Sequence[int] | None) -> NDArray[np.float64]:
    """Per joint the threshold that replaces the default (NaN: none): ``inf`` for a servo
    with a D gain, the arm file's ``collision_current_a`` over that."""
    out = np.full(k, np.nan)
    if d_gains is not None:
        out[np.asarray(d_gains) > 0] = np.inf
    if arm is not None:
        for j, joint in enumerate(arm.joints):
            if joint.collision_current is not None:
                out[j] = joint.collision_current
    return out


def thresholds(predicted: NDArray[np.float64], limits: Sequence[float],
               arm: Arm | None = None,
               d_gains: Sequence[int] | None = None) -> NDArray[np.float64]:
    """Per-joint thresholds, A: the arm file's ``collision_current_a`` where given, else
    the module's default from the predicted peak (``inf``: off, for a servo with a D gain)."""
    peak = np.abs(predicted).max(axis=0) if len(predicted) else np.zeros(len(limits))
    default = np.minimum(MARGIN_FACTOR * peak + MARGIN_A, current_caps(limits))
    fixed = _overrides(len(default), arm, d_gains)
    return np.where(np.isnan(fixed), default, fixed)


def threshold_profile(predicted: NDArray[np.float64], period: float,
                      limits: Sequence[float], arm: Arm | None = None,
                      d_gains: Sequence[int] | None = None) -> NDArray[np.float64]:
    """Per-sample thresholds (n, k), A (module notes): each sample's from the current the
    plan needs around it; a configured ``collision_current_a`` and a D-gain's ``inf`` as in
    :func:`thresholds`, whose value is the largest of these."""
    half = max(1, round(WINDOW_S / period))
    peak = _window_max(np.abs(predicted), half)
    out = np.minimum(MARGIN_FACTOR * peak + MARGIN_A, current_caps(limits))
    fixed = _overrides(predicted.shape[1], arm, d_gains)
    return np.where(np.isnan(fixed), out, fixed)


class ChainThresholds:
    """Per-sample thresholds along what an online execution commands (issue 17 §7): its
    source is a chain of nodes (:class:`robodcn.stream.online.samples.OnlineSamples`: the
    plan, then each operation's tail from its ``switch`` on, with ``prev``, ``switch`` and
    ``joints``), and a tail's motion — a retarget's, a resume's — is not the plan's: a
    retarget out of a plan that hardly moved a joint would otherwise be held to that
    plan's 0.5 A. Each node's :func:`threshold_profile` is computed once, from its joints
    and the two commanded samples before its switch (one inverse dynamics per node, on the
    first read that needs it); a sample within :data:`WINDOW_S` after a switch takes the
    larger of its node's threshold and the previous node's last one (the current of the
    motion before the switch is still decaying)."""

    def __init__(self, period: float, servos: Sequence[ServoSpec], arm: Arm | None,
                 payload_kg: float | None, limits: Sequence[float],
                 d_gains: Sequence[int] | None) -> None:
        self.period = period
        self.servos = servos
        self.arm = arm
        self.payload_kg = payload_kg
        self.limits = limits
        self.d_gains = d_gains
        self.half = max(1, round(WINDOW_S / period))
        #: id(node.joints) -> (the joints, kept alive so the id stays theirs; the profile)
        self._profiles: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

    def _profile(self, node: Any) -> NDArray[np.float64]:
        joints = node.joints
        known = self._profiles.get(id(joints))
        if known is not None and known[0] is joints:
            return known[1]
        prev = node.prev
        before = [prev.joint(i) for i in range(max(0, node.switch - 2), node.switch)] \
            if prev is not None else []
        rows = np.vstack([*before, joints]) if before else np.asarray(joints)
        predicted = predicted_currents(rows, self.period, self.servos, self.arm,
                                       self.payload_kg)
        profile = threshold_profile(predicted, self.period, self.limits, self.arm,
                                    self.d_gains)[len(before):]
        self._profiles[id(joints)] = (joints, profile)
        return profile

    def at(self, source: Any, sample: int) -> NDArray[np.float64]:
        """The thresholds (k,) A at ``sample`` of the chain ``source``."""
        node = source
        while sample < node.switch and node.prev is not None:
            node = node.prev
        profile = self._profile(node)
        out = profile[min(max(sample - node.switch, 0), len(profile) - 1)]
        prev = node.prev
        if prev is not None and sample - node.switch < self.half:
            while node.switch - 1 < prev.switch and prev.prev is not None:
                prev = prev.prev
            before = self._profile(prev)
            out = np.maximum(out, before[min(max(node.switch - 1 - prev.switch, 0),
                                             len(before) - 1)])
        return out


__all__ = ["FALLBACK_LIMIT_A", "LIMIT_SHARE", "MARGIN_A", "MARGIN_FACTOR", "SLEW_QUIET_S",
           "WINDOW_S",
           "ChainThresholds", "current_caps", "predicted_currents", "threshold_profile",
           "thresholds"]
