"""Waypoints → interpolated poses → branch-continuous joint angles → servo ticks, validated.

``plan(arm, waypoints, ...)`` builds a :class:`PlanRequest` (immutable, validated) and
returns a :class:`Trajectory` sampled exactly every 1/rate_hz seconds from t = 0
(design.md §1, §4). Nothing leaves the planner unvalidated and nothing is clamped: the first
failing sample (reach, joint limits, tick limits, finite-difference velocity and acceleration)
raises a :mod:`robodcn.errors` PlanError naming its index, time, pose and joint.

Structure of a plan
-------------------
* **Segments.** Waypoint j → j + 1 follows ``robodcn.interpolate.interpolate`` with that
  segment's method and turn; θ is chained so it stays continuous across waypoints.
* **Stops (blend=False).** Each segment has its own time law s(τ) and stops at its end
  waypoint (quintic and trapezoid are rest-to-rest; "linear" has velocity steps).
* **Blend (blend=True).** One time law over a global path parameter u ∈ [0, 1] whose knots
  are spaced by each segment's joint-space travel time; each segment's pose curve gets a
  quintic Hermite correction (zero at both ends; path.blended_path) so that at every via
  point the tangent dP/du and the second derivative d²P/du² equal the knot-weighted
  (Bessel) averages of the two neighbouring segments' (C²: the jerk stays finite). The path still
  passes exactly through every waypoint, and the velocity is continuous there; between
  waypoints the curve departs from the pure ScLERP/KenLERP/... path by that correction.
* **Approach.** With ``start_joints`` farther than half a servo tick from the IK of the first
  waypoint (the branch and 2π turn nearest start_joints, unless that turn is outside the
  joint limits and another is inside), a joint-space quintic from start_joints is
  prepended. It is always timed "auto" and comes on top of a numeric ``duration``.
* **Optimal (the default profile).** :mod:`~robodcn.planner.optimal`: the same geometry,
  timed time-optimally by :mod:`robodcn.path_timing` (whole path at once; stops at vias
  without blend; from a moving ``start_state``). The rest of this docstring describes the
  uniform profiles.
* **Duration.** A number: the path's time, rounded up to whole sample periods and split over
  stop segments in proportion to their own shortest durations. "auto": per piece, the
  smallest number of sample periods N for which the finite-difference checks pass. The
  estimate N = ⌈T_fd(N)·rate⌉ from :func:`robodcn.timing.fd_min_duration` (the closed form of
  uniform time scaling) is iterated, then confirmed: N passes and N − 1 fails (or N = 1).
  Each piece is minimal on its own; if a join between stop segments still fails (only the
  linear profile, whose velocity steps at the joins), all path pieces are slowed by the
  failing ratio and re-checked, a few times at most. A path that leaves the workspace
  cannot be timed: its UnreachableError names the first sample out of reach in the plan
  timed by the estimate, ignoring the speeds before it (which that timing did not set).

Validation is by finite differences at the sample rate: velocity (q_i − q_{i−1})·rate is
charged to sample i, acceleration (q_{i+1} − 2q_i + q_{i−1})·rate² to sample i + 1 (the
first sample that cannot be reached in time). The arm is at rest before t = 0 and after the
end (the streamer starts from a standing arm and holds the last goal), so q_{−1} = q_0 and
q_{n} = q_{n−1}: a velocity step at either end, as the linear profile has, is an acceleration
like any other (the end one is charged to the last sample). A joint with a jerk limit is
checked the same way with third differences.

Modules: :mod:`~robodcn.planner.build` (the one pipeline: pieces → timing law → sample →
validate, one retry loop, one assembly; :func:`plan`), :mod:`~robodcn.planner.uniform` and
:mod:`~robodcn.planner.optimal` (the two timing laws, :mod:`~robodcn.planner.samples`' Timing),
:mod:`~robodcn.planner.pieces` (the optimal law's dense pieces), :mod:`~robodcn.planner.path`
(segments, blending, IK), :mod:`~robodcn.planner.search` (auto timing of uniform laws),
:mod:`~robodcn.planner.validate` (checks that return :class:`~robodcn.errors.Violation`
data), :mod:`~robodcn.planner.trajectory` (Trajectory, JSON/CSV). PlanRequest and StartState
are the contract's (:mod:`robodcn.contract.request`; this package re-exports them); a
moving start joins its path by :mod:`robodcn.path_timing.moving_start`.
"""

from robodcn.contract import MAX_SAMPLES
from robodcn.contract.request import PlanRequest, StartState
from robodcn.dcn import TURNS
from robodcn.errors import BetaIgnoredWarning, BranchSwitchWarning
from robodcn.planner.build import plan, plan_request
from robodcn.planner.trajectory import Trajectory
from robodcn.planner.validate import ANGLE_SLACK, LIMIT_SLACK
from robodcn.timing import PROFILES, UNIFORM_PROFILES

__all__ = [
           "ANGLE_SLACK",
           "LIMIT_SLACK",
           "MAX_SAMPLES",
           "PROFILES",
           "TURNS",
           "UNIFORM_PROFILES",
           "BetaIgnoredWarning",
           "BranchSwitchWarning",
           "PlanRequest",
           "StartState",
           "Trajectory",
           "plan",
           "plan_request",
]
