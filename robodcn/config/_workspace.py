"""The ``[workspace]`` table: the keep-out zones no point of the arm may enter.

Three kinds of zone, each a closed region of the base frame (metres)::

    [workspace]
    floor_z = 0.0          # yawed arm: nothing below this plane (false: no floor)
    base_radius = 0.038    # yawed arm: a cylinder about the yaw axis (false: none) …
    base_height = 0.0765   # … from below the floor up to this height
    [[workspace.keep_out]] # any arm: a box, given by two opposite corners
    name = "camera"
    min = [0.15, -0.05, 0.0]    # [x, y, z] (a planar arm: [x, y])
    max = [0.25, 0.05, 0.10]

Defaults, where the table (or a key) is absent: an arm with a shoulder height (a base yaw
turning a vertical chain, the OpenMANIPULATOR-X) has the floor at the mounting plate,
z = 0, and a base cylinder around the yaw servo up to the shoulder: its radius
:func:`base_radius_of` the servo's footprint about the yaw axis. A planar arm has no floor
and no base by default; one whose plane is vertical may set ``floor_y`` (its up axis is y),
one lying flat has no floor at all (its plane has no up).
"""

from __future__ import annotations

import math

from robodcn.config._reader import Reader
from robodcn.config._specs import LINK_RANGE
from robodcn.config._zones import BASE, BOX_RANGE, FLOOR, KeepOutBox, Workspace
from robodcn.servo_models import SERVO_SPECS, ServoModel


def base_radius_of(model: ServoModel) -> float:
    """The default base cylinder's radius (m): the farthest corner of the yaw servo's
    footprint from its horn axis, hypot(length − axis_from_end, width / 2).

    The yaw servo stands with its horn up, so its footprint is width × length
    (:attr:`ServoModel.body`); the horn axis lies ``axis_from_end`` from one end of its
    length. For the XM430-W350 on the OpenMANIPULATOR-X: 28.5 × 46.5 mm, the axis 11.25 mm
    from the end (ROBOTIS's base link frame, at the body's centre, sits 12 mm behind the
    yaw axis: 46.5/2 − 12; shared/omx.md), so hypot(35.25, 14.25) mm = 38.0 mm.
    """
    width, length, _height = model.body
    return math.hypot(length - model.axis_from_end, 0.5 * width)


def _switch(r: Reader, key: str, default: float | None) -> float | None:
    """A number, or ``false`` for none; absent: ``default``."""
    if not r.has(key):
        return default
    if r.table[key] is False:
        return None
    return r.number(key)


def _box(r: Reader, i: int, planar: bool) -> KeepOutBox:
    r.only({"name", "min", "max"})
    name = r.string("name", f"keep_out[{i}]")
    if name in (FLOOR, BASE):
        raise r.fail("name", f"{FLOOR!r} and {BASE!r} name the floor and the base", name)
    n = 2 if planar else 3
    what = "[x, y]" if planar else "[x, y, z]"
    low = r.numbers("min", n, f"the corner {what} in metres") if r.has("min") else None
    high = r.numbers("max", n, f"the corner {what} in metres") if r.has("max") else None
    if low is None or high is None:
        raise r.missing("min" if low is None else "max")
    for key, values in (("min", low), ("max", high)):
        if any(abs(v) > BOX_RANGE for v in values):
            raise r.fail(key, f"must lie within ±{BOX_RANGE:g} m", r.table[key])
    for axis in range(n):
        if not low[axis] < high[axis]:
            raise r.fail("max", f"every coordinate must exceed min's ({'xyz'[axis]}: "
                         f"{high[axis]:g} ≤ {low[axis]:g} m)", r.table["max"])
    if planar:  # a planar arm's points lie in its plane: the box spans every z
        low, high = [*low, -math.inf], [*high, math.inf]
    return KeepOutBox(name, tuple(low), tuple(high))  # type: ignore[arg-type]


def workspace(r: Reader, *, base_yaw: bool, plane: str, shoulder_height: float,
              yaw_model: str | None) -> Workspace:
    """The ``[workspace]`` table of an arm (module docstring; absent: the defaults).

    ``yaw_model`` names the yaw servo's model (the base cylinder's default radius)."""
    if base_yaw:
        r.only({"floor_z", "base_radius", "base_height", "keep_out"})
        floor = _switch(r, "floor_z", 0.0)
        default_radius = None if yaw_model is None else base_radius_of(SERVO_SPECS[yaw_model])
        radius = _switch(r, "base_radius", default_radius)
        if radius is not None and not 0.0 < radius <= LINK_RANGE[1]:
            raise r.fail("base_radius", f"must be within 0..{LINK_RANGE[1]:g} m (false: no "
                         "base cylinder)", r.table["base_radius"])
        height = r.number("base_height", shoulder_height)
        if not 0.0 <= height <= LINK_RANGE[1]:
            raise r.fail("base_height", f"must be within 0..{LINK_RANGE[1]:g} m", height)
        up = 2
    else:
        r.only({"floor_y", "keep_out"})
        if r.has("floor_y") and plane != "vertical":
            raise r.fail("floor_y", "an arm lying in a horizontal plane has no floor in it "
                         "(plane = \"vertical\" has: y up)", r.table["floor_y"])
        floor, radius, height, up = _switch(r, "floor_y", None), None, 0.0, 1
    raw = r.table.get("keep_out", [])
    if not isinstance(raw, list) or not all(isinstance(b, dict) for b in raw):
        raise r.fail("keep_out", "must be an array of tables ([[workspace.keep_out]])", raw)
    boxes = tuple(_box(Reader(r.source, b, r.key_name(f"keep_out[{i}]")), i, not base_yaw)
                  for i, b in enumerate(raw))
    seen: set[str] = set()
    for i, b in enumerate(boxes):
        if b.name in seen:
            raise r.fail(f"keep_out[{i}].name", "duplicate zone name", b.name)
        seen.add(b.name)
    return Workspace(floor=floor, up=up, base_radius=radius, base_height=height, boxes=boxes)


__all__ = ["base_radius_of", "workspace"]
