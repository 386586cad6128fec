"""An arm's keep-out zones drawn where the workspace is drawn (``check-config --plot``).

A yawed arm's side view (r, z): the floor below its height, the base cylinder as the band
|r| < radius up to its top, and each box's section at yaw 0 (x → r; drawn only where the
box spans y = 0, the plane shown). A planar arm's plane (x, y): the floor of a vertical
arm below its height, each box as its rectangle.
"""

from __future__ import annotations

from robodcn.config import Arm

#: How the zones are filled: a red hatch, so the reachable points show where they are not.
STYLE = {"facecolor": "tab:red", "alpha": 0.15, "edgecolor": "tab:red", "hatch": "//"}


def draw_zones(ax, arm: Arm, span: tuple[float, float, float]) -> None:
    """Fill the zones of ``arm`` on ``ax``, the floor and the base from v_min up, over
    u_min … u_max (``span`` (u_min, u_max, v_min) of the drawing plane), labelled once
    "keep-out zone"."""
    from matplotlib.patches import Rectangle

    zones = arm.workspace
    u0, u1, v0 = span
    label: list[str | None] = ["keep-out zone"]

    def rect(u: float, v: float, w: float, h: float) -> None:
        ax.add_patch(Rectangle((u, v), w, h, label=label[0], **STYLE))
        label[0] = None

    if zones.floor is not None:
        rect(u0, v0, u1 - u0, zones.floor - v0)
    if zones.base_radius is not None:
        r = zones.base_radius
        rect(-r, v0, 2 * r, zones.base_height - v0)
    for box in zones.boxes:
        if arm.yawed:
            if box.low[1] < 0.0 < box.high[1]:
                rect(box.low[0], box.low[2], box.high[0] - box.low[0],
                     box.high[2] - box.low[2])
        else:
            rect(box.low[0], box.low[1], box.high[0] - box.low[0], box.high[1] - box.low[1])


__all__ = ["STYLE", "draw_zones"]
