"""``check-config``: validate an arm file and summarise it in the user's units (degrees).

:func:`summary` is data (a dict, SI; ``robodcn check-config`` renders it,
:func:`robodcn.cli.config_cmd.summary_text`): links, reach, the home pose in the arm's pose
keys, per joint the angle and tick ranges, the servo map and the bus, and the torque check
(:func:`torque_check`). :func:`workspace_samples` gives the tool points reachable inside the
joint limits for :func:`robodcn.plots.plot_workspace` (a yawed arm's in its vertical plane).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics, servo_units
from robodcn.config import SERVO_SPECS, Arm, clear_of_zones, rigid_chain
from robodcn.dynamics import holding_torque_box


def torque_check(arm: Arm, payload_kg: float | None = None) -> list[dict[str, Any]]:
    """Per joint (the arm's order, yaw first): the worst holding torque over its joint-limit
    box and what the servo and the file allow, with warnings.

    ``holding_torque_nm`` = max over min ≤ q ≤ max of |g_i(q)|, the gravity torque with
    ``payload_kg`` (default: the arm's ``payload_kg``) at the tool point
    (:func:`robodcn.dynamics.holding_torque_box` of :func:`robodcn.config.rigid_chain`);
    ``stall_torque_nm`` the servo's at 12 V; ``available_torque_nm`` the torque–speed line
    at the joint's top speed, τ_stall·(1 − ω_max/ω_no-load); ``max_torque_nm`` the file's
    (None: none). A warning when the holding torque exceeds the stall torque or
    max_torque_nm, and when (max_velocity, max_torque_nm) lies above the torque–speed line.
    """
    payload = arm.payload_kg if payload_kg is None else float(payload_kg)
    lower = [j.min_angle for j in arm.joints]
    upper = [j.max_angle for j in arm.joints]
    holding = holding_torque_box(rigid_chain(arm), lower, upper, payload)
    rows = []
    for joint, tau in zip(arm.joints, holding.tolist(), strict=True):
        model = SERVO_SPECS.get(joint.servo.model)
        stall = None if model is None else model.stall_torque
        available = None if model is None else model.available_torque(joint.max_velocity)
        warnings = []
        if stall is not None and tau > stall:
            warnings.append(f"holding torque {tau:.2f} N·m exceeds the servo's stall torque "
                            f"{stall:.2f} N·m: the arm cannot hold itself up everywhere in "
                            "its limits with this payload")
        if joint.max_torque is not None and tau > joint.max_torque:
            warnings.append(f"holding torque {tau:.2f} N·m exceeds max_torque_nm "
                            f"{joint.max_torque:.2f} N·m: the timing has no torque left to "
                            "move this joint in part of its range")
        if joint.max_torque is not None and available is not None and \
                joint.max_torque > available:
            warnings.append(f"max_torque_nm {joint.max_torque:.2f} N·m lies above the "
                            f"servo's torque–speed line at max_velocity "
                            f"{joint.max_velocity:.2f} rad/s ({available:.2f} N·m available): "
                            "lower one of them")
        rows.append({"name": joint.name, "holding_torque_nm": float(tau),
                     "stall_torque_nm": stall, "max_torque_nm": joint.max_torque,
                     "available_torque_nm": available, "max_velocity": joint.max_velocity,
                     "warnings": warnings})
    return rows


def _reach(arm: Arm) -> dict[str, float]:
    if arm.yawed:
        inner, outer = arm.chain.workspace()
        return {"wrist_inner": inner, "wrist_outer": outer,
                "tool_max": float(sum(arm.links)), "shoulder_height": arm.shoulder_height}
    inner, outer = kinematics.workspace(arm.links)
    return {"wrist_inner": inner, "wrist_outer": outer, "tool_max": float(sum(arm.links))}


def summary(arm: Arm, payload_kg: float | None = None) -> dict[str, Any]:
    """Links, reach, per joint the angle and tick ranges, servo map, bus and torques of
    ``arm`` (SI); ``payload_kg`` for the holding torques (default: the arm's)."""
    torques = {row["name"]: row for row in torque_check(arm, payload_kg)}
    joints = []
    for j in arm.joints:
        s = j.servo
        # The joint angles the tick range allows (direction may swap the ends).
        ends = servo_units.ticks_to_radians(np.array([[s.min_tick], [s.max_tick]]), [s])[:, 0]
        t = torques[j.name]
        joints.append({
            "name": j.name, "min": j.min_angle, "max": j.max_angle,
            "max_velocity": j.max_velocity, "max_acceleration": j.max_acceleration,
            "servo": {"id": s.id, "model": s.model, "ticks_per_turn": s.ticks_per_turn,
                      "zero_offset": s.zero_offset, "direction": s.direction,
                      "min_tick": s.min_tick, "max_tick": s.max_tick},
            "tick_range_angles": [float(ends.min()), float(ends.max())],
            "limits_inside_ticks": bool(ends.min() <= j.min_angle and j.max_angle <= ends.max()),
            **{k: t[k] for k in ("holding_torque_nm", "stall_torque_nm", "max_torque_nm",
                                 "available_torque_nm", "warnings")},
        })
    out = {"name": arm.name, "source": arm.source, "dof": arm.dof,
           "full_pose": arm.dof == 3 or arm.yawed, "yawed": arm.yawed,
           "pose_keys": list(arm.pose_keys), "links": list(arm.links),
           "reach": _reach(arm), "elbow": arm.elbow, "home": list(arm.home),
           "rest": None if arm.rest is None else list(arm.rest),
           "payload_kg": arm.payload_kg if payload_kg is None else float(payload_kg),
           "joints": joints,
           "bus": {"port": arm.bus.port, "baud": arm.bus.baud, "protocol": arm.bus.protocol,
                   "rate_hz": arm.bus.rate_hz},
           "gripper": None if arm.gripper is None else {
               "id": arm.gripper.servo.id, "model": arm.gripper.servo.model,
               "open_width_m": arm.gripper.open_width,
               "closed_width_m": arm.gripper.closed_width,
               "grip_current_a": arm.gripper.grip_current},
           "keep_out": arm.workspace.zone_list(planar=not arm.yawed)}
    if arm.yawed:
        out["link_vectors"] = arm.chain_links.tolist()
    out["warnings"] = [f"joint {j['name']!r}: {w}" for j in joints for w in j["warnings"]]
    return out


def workspace_samples(arm: Arm, per_joint: int = 41) -> NDArray[np.float64]:
    """Tool poses of a grid over the joint limits, ``per_joint`` values a joint: (n, 3)
    (x, y, θ) of a planar arm; (n, 3) (r, z, pitch) in the vertical plane of a yawed arm
    (the chain's joints only: the yaw turns that plane).

    The reachable workspace inside the joint limits (not just the annulus): FK of every
    combination, vectorised; only the combinations that keep every point of the arm out of
    its keep-out zones (:func:`robodcn.config.clear_of_zones`; a yawed arm's at yaw 0, the
    plane drawn), so nothing a plan would refuse is shown as reachable.
    """
    joints = arm.chain_joints
    axes = [np.linspace(j.min_angle, j.max_angle, per_joint) for j in joints]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(joints))
    if arm.yawed:
        full = np.column_stack([np.zeros(len(grid)), grid])
        return kinematics.plane_fk(arm.chain, grid[clear_of_zones(arm, full)])
    return kinematics.fk(arm.links, grid[clear_of_zones(arm, grid)])
