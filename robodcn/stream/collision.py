"""Collision stop: thresholds on each joint's motor current, derived from the plan.

The current a joint should draw along the plan is predicted with the arm's inverse dynamics
and the servo's motor model (:mod:`robodcn.stream.servo_model`, i = (u·V − k·q̇)/R). A
collision makes the position loop push against the obstacle, so the current climbs toward
the servo's limit while the plan does not ask for it. Default threshold per joint::

    I_th = min(2·max_t |i_pred(t)| + 0.5 A,  0.9·I_limit)

(a factor 2 and 0.5 A for model error and for the goal jumps of samples a loaded host had
to skip, which the simulator showed to reach 3× the prediction for a few cycles; a blocked
joint heads for its stall current, 2.3 A on an XM430, well above; below the current limit,
where the firmware's overload would otherwise act first). ``collision_current_a`` per joint in
the arm file, or ``ExecutionOptions.collision_current``, overrides it.

A servo with a Position D Gain (the XL430-W250's factory 4000) answers every streamed goal
step with a derivative kick, PWM = KPD·Δg for one control millisecond, which the read right
after the write catches: its current readings jump to the limit while it follows the plan
well. No default threshold separates that from a collision, so the default stop is off for
such a joint (``inf``; the streamer warns "collision_stop_off"); a configured
``collision_current_a`` still applies. The stream stops when
a joint's |current| stays above its threshold for ``collision_cycles`` consecutive feedback
reads.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from robodcn.config import Arm, ServoSpec
from robodcn.stream.compensation import plan_load
from robodcn.stream.servo_model import derivatives, motor_of

#: Model-error factor and absolute margin of the default threshold (module notes).
MARGIN_FACTOR = 2.0
MARGIN_A = 0.5
#: The default threshold stays below this share of the servo's current limit.
LIMIT_SHARE = 0.9


def predicted_currents(joints: NDArray[np.float64], period: float,
                       servos: Sequence[ServoSpec], arm: Arm | None) -> NDArray[np.float64]:
    """Motor current (A, joint sign) each joint draws along the plan, (n, k)."""
    qd, qdd = derivatives(joints, period)
    load = plan_load(arm, joints, qd, qdd)
    return np.column_stack([motor_of(s.model).current(qd[:, j], qdd[:, j], load[:, j])
                            for j, s in enumerate(servos)])


def thresholds(predicted: NDArray[np.float64], limits: Sequence[float],
               arm: Arm | None = None,
               d_gains: Sequence[int] | None = None) -> NDArray[np.float64]:
    """Per-joint thresholds, A: the arm file's ``collision_current_a`` where given, else
    the module's default from the predicted peak (``inf``: off, for a servo with a D gain)."""
    peak = np.abs(predicted).max(axis=0) if len(predicted) else np.zeros(len(limits))
    default = np.minimum(MARGIN_FACTOR * peak + MARGIN_A, LIMIT_SHARE * np.asarray(limits))
    if d_gains is not None:
        default[np.asarray(d_gains) > 0] = np.inf
    if arm is not None:
        for j, joint in enumerate(arm.joints):
            if joint.collision_current is not None:
                default[j] = joint.collision_current
    return default


__all__ = ["LIMIT_SHARE", "MARGIN_A", "MARGIN_FACTOR", "predicted_currents", "thresholds"]
