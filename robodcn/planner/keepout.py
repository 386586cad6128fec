"""Keep-out zones on joint samples the planner did not sample itself.

A plan's own samples are checked in :func:`robodcn.planner.validate.check` (with the joint
limits); the samples an online retarget sends after its switch (a moving start's blend or
brake, the way through rest) and a single pose a surface is about to record are checked
here, with the same points and zones (:func:`robodcn.config.first_intrusion`) and the
same error: :class:`~robodcn.errors.KeepOutError` carrying a "keepout"
:class:`~robodcn.errors.Violation`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from robodcn.config import Arm, first_intrusion
from robodcn.errors import KeepOutError, Violation
from robodcn.messages import describe_violation, point_name
from robodcn.planner.path import user_pose


def check_joints(arm: Arm, joints: ArrayLike, rate_hz: float, *,
                 field: str = "waypoints") -> None:
    """Raise KeepOutError when a sample of ``joints`` (n, k), sent every 1/``rate_hz`` s,
    puts a point of ``arm`` inside one of its keep-out zones (the first such sample: the
    point, the zone, how deep; ``field`` the request field to change)."""
    q = np.asarray(joints, dtype=np.float64)
    if q.ndim != 2 or arm.workspace.empty:
        return
    hit = first_intrusion(arm, q)
    if hit is None:
        return
    i = hit.sample
    pose = user_pose(arm, q[i:i + 1])[0]
    j = hit.joint
    violation = Violation(sample=i, t=i / rate_hz, pose=tuple(float(v) for v in pose),
                          quantity="keepout", value=hit.depth, limit=0.0, unit="m",
                          joint=None if j is None else arm.joints[j].name, joint_index=j,
                          field=field, point=hit.point, zone=hit.zone,
                          position=hit.position)
    raise KeepOutError(describe_violation(violation, "si"), violation=violation)


def check_pose(arm: Arm, joints: ArrayLike, field: str = "joints") -> None:
    """Raise KeepOutError when the arm at ``joints`` (k,) (a pose about to be recorded, a
    target to follow) has a point inside one of its keep-out zones: which point, where,
    the zone and how deep, in mm (``field``: the request field that gave it)."""
    q = np.asarray(joints, dtype=np.float64).reshape(1, -1)
    if arm.workspace.empty:
        return
    hit = first_intrusion(arm, q, motion=False)
    if hit is None:
        return
    x, y, z = hit.position
    name = point_name(hit.point, hit.joint is not None)
    raise KeepOutError(f"the arm's {name} is at x={x:.4f} m, y={y:.4f} m, z={z:.4f} m, "
                       f"{hit.depth * 1e3:.1f} mm inside the arm's keep-out zone "
                       f"{arm.workspace.describe(hit.zone)}: no plan may go there; move the "
                       "arm clear of it", field=field,
                       value=q[0].tolist(), point=hit.point, zone=hit.zone, depth=hit.depth,
                       position=list(hit.position),
                       joint=None if hit.joint is None else arm.joints[hit.joint].name)


__all__ = ["check_joints", "check_pose"]
