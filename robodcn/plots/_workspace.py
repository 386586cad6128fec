"""The workspace ``check-config --plot`` draws: the tool points inside the joint limits and
clear of the keep-out zones, and the zones."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from robodcn import kinematics
from robodcn.config import Arm
from robodcn.plots._motion import _draw_arm, _pyplot, save_figure
from robodcn.plots._yawed import plot_plane_workspace
from robodcn.plots._zones import draw_zones


def plot_workspace(path: str, arm: Arm, points: NDArray[np.float64]) -> None:
    """The tool points reachable inside the joint limits (``points`` (n, 3), e.g.
    :func:`robodcn.workflow.check.workspace_samples`), the wrist annulus and the arm at home;
    a yawed arm's in its vertical plane (r, z; :func:`robodcn.plots._yawed.
    plot_plane_workspace`)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 7))
    if arm.yawed:
        plot_plane_workspace(ax, arm, points)
        _finish(fig, ax, plt, path)
        return
    ax.plot(points[:, 0], points[:, 1], ".", ms=1, color="tab:blue", alpha=0.3,
            label="tool points inside the joint limits, clear of the keep-out zones")
    inner, outer = kinematics.workspace(arm.links)
    draw_zones(ax, arm, (-sum(arm.links), sum(arm.links), -sum(arm.links)))
    circle = np.linspace(0, 2 * np.pi, 361)
    for radius, name in ((outer, "wrist reach"), (inner, None)):
        if radius > 0:
            ax.plot(radius * np.cos(circle), radius * np.sin(circle), "--", color="tab:gray",
                    lw=1, label=name)
    home = kinematics.ik(arm.links, [arm.home], arm.elbow)[0]
    _draw_arm(ax, arm.links, home, "tab:green", "arm at home")
    ax.plot(arm.home[0], arm.home[1], "kx", ms=9, mew=2)
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal",
           title=f"arm {arm.name!r}: reachable workspace")
    _finish(fig, ax, plt, path)


def _finish(fig, ax, plt, path: str) -> None:
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", loc="lower left")
    fig.tight_layout()
    save_figure(fig, plt, path)
