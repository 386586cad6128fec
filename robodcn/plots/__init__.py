"""Pictures of a motion and of an arm's workspace (matplotlib, imported only when drawing).

- :mod:`robodcn.plots._motion` — :func:`plot_motion`, the one plot behind ``plan``/``sim``/
  ``move``/``run --plot`` (the path, joint velocity and acceleration against the limits,
  after a run the tracking error and current)
- :mod:`robodcn.plots._yawed` — an arm with a base yaw: the side view of its vertical plane
  and the top view of the yaw
- :mod:`robodcn.plots._workspace` — :func:`plot_workspace`, what ``check-config --plot``
  draws
"""

from robodcn.plots._marks import approach_end, waypoint_samples
from robodcn.plots._motion import (
    FEW_READS,
    NEAR_SHARE,
    ORIENTATION_TICKS,
    arm_points,
    joint_rates,
    plot_motion,
    require_matplotlib,
)
from robodcn.plots._workspace import plot_workspace
from robodcn.plots._yawed import plane_points

__all__ = ["FEW_READS", "NEAR_SHARE", "ORIENTATION_TICKS", "approach_end", "arm_points",
           "joint_rates", "plane_points", "plot_motion", "plot_workspace", "require_matplotlib",
           "waypoint_samples"]
