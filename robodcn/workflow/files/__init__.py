"""Files ``robodcn run`` plays: a waypoints TOML, a Trajectory JSON, a JointTrajectory JSON.

- **Waypoints TOML** (``robodcn teach`` writes one): ``[[waypoints]]`` tables with the
  arm's pose keys — ``x``, ``y`` (metres) and ``theta_deg`` (or ``theta``, radians); on an
  arm with a base yaw ``x``, ``y``, ``z`` and ``pitch_deg`` (or ``pitch``) — optionally
  ``method`` / ``turn`` / ``beta`` (KenLERP β) for the segment that leads to that waypoint,
  ``gripper = "open" | "close"`` and ``payload_kg`` acted on there; a ``[plan]`` table with
  ``method``, ``beta``, ``turn`` (the defaults of segments whose waypoint gives none),
  ``duration`` (seconds or "auto"), ``profile``, ``rate_hz``, ``blend``, ``payload_kg``,
  ``tool_speed``, ``tool_angular_speed``, ``tool_acceleration`` (SI); an
  optional ``arm`` (the example name or config file it was taught on, :func:`waypoints_arm`).
  :func:`load_waypoints` → :class:`WaypointsPlan`,
  whose :meth:`~WaypointsPlan.plan_fields` are :class:`robodcn.planner.PlanRequest` fields
  (:mod:`._waypoints`).
- **Trajectory JSON** (``robodcn plan --format json``): :meth:`robodcn.planner.Trajectory.from_json`
  with the arm, then checked against this arm's limits and calibration.
- **JointTrajectory JSON**, the shape of ROS ``trajectory_msgs/JointTrajectory``:
  ``joint_names``, ``points`` each with ``positions`` (rad), optional ``velocities`` (rad/s)
  and ``accelerations`` (rad/s²), ``time_from_start {sec, nanosec}``. Joint names must be
  the arm's (any order). Time is shifted so the first point is at t = 0 (the arm approaches
  it first). Resampled at the stream rate by piecewise Hermite interpolation: quintic when
  accelerations are given, cubic with the given velocities, and without velocities cubic with
  the three-point estimate v_k = (p_{k+1} − p_{k−1}) / (t_{k+1} − t_{k−1}) (zero at the first
  and last point: the arm starts and ends at rest). A straight-line interpolation, as a ROS
  controller does with positions only, would step the velocity at every point.

Every parsing problem is an InputError naming the file, the point index and the field; the
resampled motion is checked like a plan (joint and tick limits, velocity and acceleration by
finite differences with the arm at rest before and after) and a violation is the matching
PlanError naming the file, the point the motion is heading to, the time and the joint.

One module per kind: :mod:`._waypoints`, :mod:`._saved` (Trajectory JSON, which kind a file
is), :mod:`._joint` (JointTrajectory), :mod:`._samples` (the checks of sampled joint
motion), :mod:`._approach` (the joint-space approach).
"""

from __future__ import annotations

from robodcn.workflow.files._approach import with_approach
from robodcn.workflow.files._joint import (
    estimate_velocities,
    hermite,
    joint_trajectory,
    load_joint_trajectory,
)
from robodcn.workflow.files._samples import check_joint_samples
from robodcn.workflow.files._saved import file_kind, load_trajectory, trajectory_from_data
from robodcn.workflow.files._waypoints import (
    ACTION_KEYS,
    GRIPPER_ACTIONS,
    PLAN_KEYS,
    SEGMENT_DEFAULTS,
    WaypointsPlan,
    load_waypoints,
    waypoints_arm,
)

__all__ = ["ACTION_KEYS", "GRIPPER_ACTIONS", "PLAN_KEYS", "SEGMENT_DEFAULTS", "WaypointsPlan",
           "check_joint_samples", "estimate_velocities", "file_kind", "hermite",
           "joint_trajectory", "load_joint_trajectory", "load_trajectory", "load_waypoints",
           "trajectory_from_data", "waypoints_arm", "with_approach"]
