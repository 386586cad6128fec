"""robodcn: smooth planar rigid-motion trajectories with dual complex numbers, streamed to
Dynamixel servos."""

from robodcn import dcn, dualquat, errors
from robodcn.interpolate import blend, interpolate

__all__ = ["blend", "dcn", "dualquat", "errors", "interpolate"]
__version__ = "0.1.0"

from robodcn.config import Arm, load_arm
from robodcn.planner import PlanRequest, Trajectory, plan, plan_request

__all__ += ["Arm", "PlanRequest", "Trajectory", "load_arm", "plan", "plan_request"]
