"""Keep-out zones as data and geometry: the floor plane, the base cylinder and boxes.

:class:`Workspace` holds an arm's zones (parsed from ``[workspace]`` by
:mod:`robodcn.config._workspace`) and measures how deep points lie inside each, vectorised
over any leading axes: depth > 0 inside, ≤ 0 outside (a point on a zone's surface is
outside, so a tool resting on the table is allowed).

Depth of a point p = (x, y, z):

* floor at height f on the up axis u: f − p_u
* base cylinder of radius R about the z axis up to height H: min(R − hypot(x, y), H − z)
  (it reaches down past the floor: below it the floor's depth is the one that matters)
* box [lo, hi]: min over the axes of min(p − lo, hi − p)

Each is the distance the point must travel to leave the zone along the nearest way out
(through the floor plane, the cylinder's wall or lid, a box's nearest face): "how deep".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: The zone name of the floor plane and of the base cylinder (a box's is its ``name``).
FLOOR, BASE = "floor", "base"
#: Box corners accepted (m from the base): far past any Dynamixel arm's reach.
BOX_RANGE = 40.0


@dataclass(frozen=True)
class KeepOutBox:
    """An axis-aligned box of the base frame no point of the arm may enter: corners
    ``low`` ≤ ``high`` (x, y, z) in metres (a planar arm's z spans −inf … inf)."""

    name: str
    low: tuple[float, float, float]
    high: tuple[float, float, float]

    def to_dict(self, planar: bool) -> dict[str, Any]:
        n = 2 if planar else 3
        return {"name": self.name, "min": list(self.low[:n]), "max": list(self.high[:n])}


@dataclass(frozen=True)
class Workspace:
    """An arm's keep-out zones (``[workspace]``), SI.

    floor : height (m) of the floor plane on the ``up`` axis, or None: no floor
    up : the index of the up axis in a base-frame point (2: z of a yawed arm; 1: y of a
        planar arm standing in a vertical plane)
    base_radius : radius (m) of the cylinder about the yaw axis that holds the base, or
        None: none
    base_height : the cylinder's top (m above the plate); it reaches down past the floor
    boxes : the ``[[workspace.keep_out]]`` boxes
    """

    floor: float | None = None
    up: int = 2
    base_radius: float | None = None
    base_height: float = 0.0
    boxes: tuple[KeepOutBox, ...] = ()

    @property
    def zones(self) -> tuple[str, ...]:
        """The zones' names, in the order the checks report them: floor, base, boxes."""
        return ((FLOOR,) if self.floor is not None else ()) + \
            ((BASE,) if self.base_radius is not None else ()) + \
            tuple(b.name for b in self.boxes)

    @property
    def empty(self) -> bool:
        """Whether the arm has no zone at all (nothing to check)."""
        return self.floor is None and self.base_radius is None and not self.boxes

    def to_dict(self, planar: bool) -> dict[str, Any]:
        """The ``[workspace]`` table, every key explicit (``false``: no such zone), in SI
        keys that :func:`workspace` reads back to this workspace."""
        out: dict[str, Any] = {}
        if planar:
            if self.floor is not None:
                out["floor_y"] = self.floor
        else:
            out["floor_z"] = False if self.floor is None else self.floor
            out["base_radius"] = False if self.base_radius is None else self.base_radius
            out["base_height"] = self.base_height
        if self.boxes:
            out["keep_out"] = [b.to_dict(planar) for b in self.boxes]
        return out

    def zone_list(self, planar: bool) -> list[dict[str, Any]]:
        """The zones as JSON data, in :attr:`zones` order (``GET /v1/arm``; the console
        draws them): ``{"name", "kind": "floor", "axis": "z" | "y", "height"}``,
        ``{"name", "kind": "cylinder", "radius", "top"}`` (about the yaw axis, from below
        the floor), ``{"name", "kind": "box", "min", "max"}`` ([x, y, z]; a planar arm's
        [x, y]); metres."""
        out: list[dict[str, Any]] = []
        if self.floor is not None:
            out.append({"name": FLOOR, "kind": "floor", "axis": "xyz"[self.up],
                        "height": self.floor})
        if self.base_radius is not None:
            out.append({"name": BASE, "kind": "cylinder", "radius": self.base_radius,
                        "top": self.base_height})
        out += [{"kind": "box", **b.to_dict(planar)} for b in self.boxes]
        return out

    def describe(self, name: str) -> str:
        """A zone in words for messages: "'floor' (z < 0.000 m)", "'base' (the cylinder
        r < 0.038 m about the yaw axis, up to z = 0.077 m)", "'camera' (the box …)"."""
        if name == FLOOR and self.floor is not None:
            axis = "xyz"[self.up]
            return f"{FLOOR!r} ({axis} < {self.floor:.3f} m)"
        if name == BASE and self.base_radius is not None:
            return (f"{BASE!r} (the cylinder r < {self.base_radius:.3f} m about the yaw "
                    f"axis, up to z = {self.base_height:.3f} m)")
        for b in self.boxes:
            if b.name == name:
                n = 2 if self.up == 1 or math.isinf(b.low[2]) else 3
                lo = ", ".join(f"{v:.3f}" for v in b.low[:n])
                hi = ", ".join(f"{v:.3f}" for v in b.high[:n])
                return f"{name!r} (the box [{lo}] … [{hi}] m)"
        return name

    def depths(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Depth (..., z) of points (..., 3) inside each zone, in :attr:`zones` order (m;
        > 0 inside; module docstring)."""
        p = np.asarray(points, dtype=np.float64)
        out = []
        if self.floor is not None:
            out.append(self.floor - p[..., self.up])
        if self.base_radius is not None:
            rho = np.hypot(p[..., 0], p[..., 1])
            out.append(np.minimum(self.base_radius - rho, self.base_height - p[..., 2]))
        for b in self.boxes:
            lo, hi = np.asarray(b.low), np.asarray(b.high)
            out.append(np.minimum(p - lo, hi - p).min(axis=-1))
        if not out:
            return np.zeros((*p.shape[:-1], 0))
        return np.stack(out, axis=-1)


__all__ = ["BASE", "BOX_RANGE", "FLOOR", "KeepOutBox", "Workspace"]
