"""Loading an arm: the whole document checked part by part, then its home and rest poses."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from robodcn import kinematics
from robodcn.config._body import first_intrusion
from robodcn.config._dynamics import dynamics
from robodcn.config._examples import EXAMPLES, arm_path
from robodcn.config._geometry import geometry
from robodcn.config._parts import bus, gripper, joint
from robodcn.config._reader import Reader
from robodcn.config._specs import Arm
from robodcn.config._tool import tool
from robodcn.config._workspace import workspace
from robodcn.errors import ConfigError


def arm_from_dict(data: Any, source: str = "<dict>") -> Arm:
    """Build and validate an :class:`Arm` from a parsed TOML document (or an equal dict).

    Raises
    ------
    ConfigError
        Naming ``source``, the dotted key and the value: unknown or missing keys, wrong
        types, non-positive lengths or limits, bad servo ids or tick ranges, duplicate
        names or ids, a home or rest pose out of reach (or, on a yawed arm, outside the
        joint limits).
    """
    top = Reader(source, data, "")
    top.only({"arm", "bus", "joints", "dynamics", "gripper", "tool", "workspace"})
    geo = geometry(top.sub("arm"))
    bus_spec = bus(top.sub("bus"))
    n_joints = len(geo.lengths) + (1 if geo.base_yaw else 0)

    joints_raw = top.table.get("joints")
    if joints_raw is None:
        raise top.missing("joints")
    if not isinstance(joints_raw, list):
        raise top.fail("joints", "must be an array of tables ([[joints]])", joints_raw)
    if len(joints_raw) != n_joints:
        per = "the yaw and one per link" if geo.base_yaw else "one joint per link"
        raise top.fail("joints", f"needs {per} ({n_joints}), got {len(joints_raw)}",
                       joints_raw)
    joints = tuple(joint(Reader(source, j, f"joints[{i}]")) for i, j in enumerate(joints_raw))
    seen_names: dict[str, int] = {}
    seen_ids: dict[int, int] = {}
    for i, spec in enumerate(joints):
        if spec.name in seen_names:
            raise ConfigError(f"key 'joints[{i}].name' = {spec.name!r}: duplicate of "
                              f"joints[{seen_names[spec.name]}]", file=source,
                              key=f"joints[{i}].name", value=spec.name)
        if spec.servo.id in seen_ids:
            raise ConfigError(f"key 'joints[{i}].servo.id' = {spec.servo.id}: duplicate of "
                              f"joints[{seen_ids[spec.servo.id]}].servo.id", file=source,
                              key=f"joints[{i}].servo.id", value=spec.servo.id)
        seen_names[spec.name] = i
        seen_ids[spec.servo.id] = i
    grip = gripper(top.sub("gripper")) if top.has("gripper") else None
    if grip is not None and grip.servo.id in seen_ids:
        raise ConfigError(f"key 'gripper.id' = {grip.servo.id}: the gripper's servo id is "
                          f"joints[{seen_ids[grip.servo.id]}].servo.id's", file=source,
                          key="gripper.id", value=grip.servo.id)
    table, props = dynamics(top.sub("dynamics", {}), len(geo.lengths), n_joints, geo.base_yaw)
    zones = workspace(top.sub("workspace", {}), base_yaw=geo.base_yaw, plane=geo.plane,
                      shoulder_height=geo.shoulder_height,
                      yaw_model=joints[0].servo.model if geo.base_yaw else None)
    arm = Arm(geo.name, geo.lengths, joints, geo.home, geo.elbow, bus_spec, source, table,
              base_yaw=geo.base_yaw, plane=geo.plane, shoulder_height=geo.shoulder_height,
              link_vectors=geo.vectors, rest=geo.rest, gripper=grip, mass_properties=props,
              tool=tool(top.sub("tool", {})), workspace=zones)
    _check_pose(arm, "home", arm.home)
    _check_clear(arm, "home", arm.home)
    if arm.rest is not None:
        _check_pose(arm, "rest", arm.rest)
        _check_clear(arm, "rest", arm.rest)
    return arm


def _check_clear(arm: Arm, which: str, pose: tuple[float, ...]) -> None:
    """The arm at its home or rest pose (IK on its elbow branch) must be clear of every
    keep-out zone: a zone that swallows it is a mistake in ``[workspace]``."""
    if arm.workspace.empty:
        return
    if arm.base_yaw:
        chain = arm.chain
        assert chain is not None
        q = kinematics.ik_yawed(chain, np.array([pose]), arm.elbow)
    else:
        q = kinematics.ik(arm.links, np.array([pose]), arm.elbow)
    hit = first_intrusion(arm, q, motion=False)
    if hit is None:
        return
    raise ConfigError(f"key 'workspace' = a table: at its {which} pose the arm's {hit.point} "
                      f"is {hit.depth * 1e3:.1f} mm inside keep-out zone "
                      f"{arm.workspace.describe(hit.zone)}", file=arm.source, key="workspace",
                      value=hit.zone)


def _check_pose(arm: Arm, which: str, pose: tuple[float, ...]) -> None:
    """A planar arm's pose must be in reach; a yawed arm's must have an IK solution on the
    arm's elbow branch within every joint's limits."""
    key = f"arm.{which}"
    if not arm.base_yaw:
        inner, outer = kinematics.workspace(arm.links)
        radius = float(kinematics.wrist_radius(arm.links, [pose])[0])
        if not (inner - kinematics.REACH_TOLERANCE <= radius
                <= outer + kinematics.REACH_TOLERANCE):
            raise ConfigError(f"key {key!r} = {list(pose)!r}: {which} pose is out of reach "
                              f"(wrist point {radius:.4f} m from the base, the arm reaches "
                              f"{inner:.4f}..{outer:.4f} m)", file=arm.source, key=key,
                              value=list(pose))
        return
    chain = arm.chain
    assert chain is not None
    shown = {"x": pose[0], "y": pose[1], "z": pose[2], "pitch_deg": round(math.degrees(pose[3]), 9)}
    why = kinematics.why_unreachable(chain, pose)
    if why is not None:
        raise ConfigError(f"key {key!r} = {shown!r}: the {which} pose {why}", file=arm.source,
                          key=key, value=shown)
    q = kinematics.ik_yawed(chain, np.array([pose]), arm.elbow)[0]
    for j, angle in zip(arm.joints, q, strict=True):
        if not j.min_angle - 1e-9 <= angle <= j.max_angle + 1e-9:
            raise ConfigError(
                f"key {key!r} = {shown!r}: the {which} pose needs joint {j.name!r} at "
                f"{angle:.4f} rad, outside its limits {j.min_angle:g}..{j.max_angle:g} rad "
                f"(elbow {arm.elbow!r})", file=arm.source, key=key, value=shown)


def load_arm(path: str | Path) -> Arm:
    """Read and validate an arm TOML file (see the module docstring for its layout), or the
    packaged example a name gives (``"arm3r"``, ``"arm2r"``, ``"omx"``: :data:`EXAMPLES`)
    when no file of that name exists, as ``--arm`` takes them.

    Raises
    ------
    ConfigError
        The file is missing, not valid TOML, or any key is unknown, missing or impossible;
        the message names the file, key and value.
    """
    path = arm_path(path)
    source = str(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        examples = (f" (nor an example arm: {', '.join(EXAMPLES)})"
                    if isinstance(exc, FileNotFoundError) else "")
        raise ConfigError(f"cannot read arm config: {exc.strerror}{examples}", file=source,
                          key=None, value=source) from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"arm config is not UTF-8 text: {exc}", file=source, key=None,
                          value=source) from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"invalid TOML: {exc}", file=source, key=None, value=None) from exc
    return arm_from_dict(data, source=source)
